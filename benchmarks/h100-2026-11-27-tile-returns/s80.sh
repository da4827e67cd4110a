#!/usr/bin/env bash
# Where 8e13650's fixed-point tile spends what the timing-only variant without returns (ptx-noret)
# saved: timing-only variants of 8e13650's kernels, v3 without the mass balance's adds (tile_scatter
# returns nothing), v4 without the particle's reach (every particle in its tile taken); ncu of
# one_pass_fixed at the dam break, be487f5 against 8e13650; racecheck of the binned fixed-point
# dam break with be487f5's kernels (did it fail before too?).
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s80
cases=("--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point")
for v in noret v3 v4; do echo "== 8e13650 against ptx-$v"; OUT=$OUT/s80/$v RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-$v "${cases[@]}" 2>&1 | grep "^| \`"; done | tee $OUT/s80/ab.txt
for side in head new; do
  env_ptx=(); [ $side = head ] && env_ptx=(MPM_PTX_DIR=$G/ptx-head)
  env "${env_ptx[@]}" timeout 150 ncu --clock-control none --set full -k regex:one_pass_fixed --launch-skip 300 --launch-count 1 -o /tmp/opf-$side $M bench --scene dam-break --scatter fixed-point --steps 400 --warmup 10 > /tmp/ncu.log 2>&1; echo "ncu $side rc $?"
  ncu -i /tmp/opf-$side.ncu-rep --page source --csv --print-source sass > /tmp/opf-sass.csv 2>&1; python3 scripts/ncu-stalls.py /tmp/opf-sass.csv > $OUT/s80/ncu-$side-stalls.txt 2>&1; head -30 $OUT/s80/ncu-$side-stalls.txt
  ncu -i /tmp/opf-$side.ncu-rep --page details 2>&1 | grep -E "Duration|Registers Per|Achieved Occ|Executed Ipc A|Issue Slots Busy|Executed Instructions  " | head -8 | tee $OUT/s80/ncu-$side-details.txt
done
cd /tmp; MPM_PTX_DIR=$G/ptx-head timeout 150 compute-sanitizer --tool racecheck --error-exitcode 9 $M run --backend cuda --scene dam-break --pipeline binned --scatter fixed-point --frames 2 > /tmp/san.log 2>&1; echo "racecheck binned fixed, be487f5's kernels: rc=$?"; tail -8 /tmp/san.log | tee $OUT/s80/racecheck-head.txt
