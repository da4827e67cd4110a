#!/usr/bin/env bash
# one_pass_float: shuffle steps as the warp's longest run needs ({3,4,5}: ptx-steps; {2,3,4,5}: ptx-steps2)
# against the warp-listed marks alone (ptx-marks); same binary, MPM_PTX_DIR.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s55
cases=("--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene fountain")
OUT=$OUT/s55/ab RUNS=2 bash scripts/bench-ab.sh $M@$G/ptx-marks $M@$G/ptx-steps "${cases[@]}" 2>&1 | tail -10 | tee $OUT/s55/ab.txt
OUT=$OUT/s55/ab16 RUNS=2 STEPS=300 WARMUP=100 bash scripts/bench-ab.sh $M@$G/ptx-marks $M@$G/ptx-steps "--particles 16777216 --grid 256" 2>&1 | tail -3 | tee -a $OUT/s55/ab.txt
OUT=$OUT/s55/ab2 RUNS=2 bash scripts/bench-ab.sh $M@$G/ptx-steps $M@$G/ptx-steps2 "${cases[@]}" 2>&1 | tail -9 | tee $OUT/s55/ab2.txt
export MPM_PTX_DIR=$G/ptx-steps
for t in gpu_kernels gpu_physics scenarios; do timeout 200 .gpu/tests/$t-* 2>&1 | grep -E "^test result|FAILED|panicked" ; done | tee $OUT/s55/tests.txt
timeout 120 ncu --clock-control none --set full --import-source yes -k regex:one_pass --launch-skip 30 --launch-count 1 -o /tmp/op $M bench --scene dam-break --steps 40 --warmup 10 > /tmp/ncu.log 2>&1; echo "ncu rc $?"
ncu -i /tmp/op.ncu-rep --page source --csv --print-source sass > /tmp/op-sass.csv 2>&1; python3 scripts/ncu-stalls.py /tmp/op-sass.csv > $OUT/s55/ncu-one_pass-stalls.txt 2>&1; head -24 $OUT/s55/ncu-one_pass-stalls.txt
ncu -i /tmp/op.ncu-rep --page details > $OUT/s55/ncu-details.txt 2>&1; grep -E "Duration|Achieved Occupancy|Registers Per" $OUT/s55/ncu-details.txt
