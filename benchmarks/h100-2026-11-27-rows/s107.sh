#!/usr/bin/env bash
# s107: issue 18's table, 3a153e5 (the issue's start, its own binary and kernels) against 0d24fd3
# (this session's end of the kernels), one machine, interleaved; 0d24fd3 against 767bb73's kernels
# (ptx-a, the session's start) by bench-ab; Nsight Compute of one_pass (the viewer: s109).
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm O=$PWD/.gpu/old/mpm-3a153e5 G=$PWD/.gpu
S=$OUT/summary.txt
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $S
cases=("--scene dam-break" "--scene bench-655k" "--scene dam-break-1m" "--scene bench-65k" "--scene fountain" "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene dam-break --pipeline binned")
(echo "== 767bb73's kernels (ptx-a) against 0d24fd3"; OUT=/tmp/ab RUNS=2 bash scripts/bench-ab.sh $M@$G/ptx-a $M "${cases[@]}" 2>&1 | grep "^| \`"
 OUT=/tmp/ab16 RUNS=1 STEPS=300 WARMUP=100 bash scripts/bench-ab.sh $M@$G/ptx-a $M "--particles 16777216 --grid 256" 2>&1 | grep "^| \`") | tee -a $S
(echo "== issue 18's table: 3a153e5 against 0d24fd3"
for c in "--scene bench-655k" "--scene bench-65k" "--scene dam-break" "--scene bench-655k --scatter fixed-point" "--scene dam-break-1m" "--particles 16777216 --grid 256 --steps 300 --warmup 100"; do
  for v in old new old new; do B=$M; [ $v = old ] && B=$O
    case "$c" in *1m*) [ $v = old ] && continue;; esac
    st="--steps 2000 --warmup 200"; case "$c" in *steps*) st="";; esac
    echo "$v $c: $(timeout 120 env -u MPM_PTX_DIR $B bench $c $st 2>&1 | grep -E '\*\*total' | head -1)"
  done; done
for sc in "dam-break --size 960x540" "dam-break --size 1920x1080" "dam-break-1m --size 960x540"; do for v in old new old new; do B=$M; [ $v = old ] && B=$O
  case "$sc" in *1m*) [ $v = old ] && continue;; esac
  echo "== $v render $sc"; timeout 90 $B render --scene $sc --frames 90 --no-images 2>&1 | grep -E "frames via|GPU ms"; done; done) | tee -a $S
(cd /tmp; for sc in "bench-655k" "dam-break-1m"; do
  timeout 120 ncu --clock-control none --kernel-name one_pass_float_planes --launch-skip 300 --launch-count 1 --section SpeedOfLight --section Occupancy --section WarpStateStats --section LaunchStats $M bench --scene $sc --steps 400 --warmup 0 > $OUT/ncu-$sc.txt 2>&1; echo "ncu $sc rc $?"; done
 timeout 150 ncu --clock-control none --kernel-name one_pass_float_planes --launch-skip 20 --launch-count 1 --section SpeedOfLight --section Occupancy --section WarpStateStats --section MemoryWorkloadAnalysis $M bench --particles 16777216 --grid 256 --steps 40 --warmup 0 > $OUT/ncu-16m.txt 2>&1; echo "ncu 16m rc $?") >> $S
cat $S
