#!/usr/bin/env bash
# one_pass_float lists its node blocks warp by warp, no barriers (working tree) against HEAD 69d4162's
# kernels (same binary, MPM_PTX_DIR); the same at 6 blocks per SM; the kernel tests; sanitizers; ncu.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s54
cases=("--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point")
OUT=$OUT/s54/ab RUNS=2 bash scripts/bench-ab.sh $M@$PWD/.gpu/ptx-head $M "${cases[@]}" 2>&1 | tail -12 | tee $OUT/s54/ab.txt
OUT=$OUT/s54/ab16 RUNS=2 STEPS=300 WARMUP=100 bash scripts/bench-ab.sh $M@$PWD/.gpu/ptx-head $M "--particles 16777216 --grid 256" 2>&1 | tail -5 | tee -a $OUT/s54/ab.txt
OUT=$OUT/s54/fb6 RUNS=2 bash scripts/bench-ab.sh $M $M@$PWD/.gpu/ptx-fb6 "${cases[@]:0:4}" 2>&1 | tail -10 | tee $OUT/s54/fb6.txt
sc=$PWD/benchmarks/h100-2026-11-25-mirror-in-update/dam-break-crossing.toml
for tool in memcheck racecheck; do for s in float fixed-point; do timeout 60 compute-sanitizer --tool $tool --error-exitcode 9 $M run --backend cuda --scene $sc --frames 2 --scatter $s > /tmp/san.log 2>&1; echo "$tool crossing $s: rc=$? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/san.log)"; done; done | tee $OUT/s54/sanitize.txt
for t in gpu_kernels gpu_physics gpu_lifecycle scenarios walls; do timeout 200 .gpu/tests/$t-* 2>&1 | grep -E "^test result|FAILED|panicked" ; done | tee $OUT/s54/tests.txt
timeout 120 ncu --clock-control none --set full --import-source yes -k regex:one_pass --launch-skip 30 --launch-count 1 -o /tmp/op $M bench --scene dam-break --steps 40 --warmup 10 > /tmp/ncu.log 2>&1; echo "ncu rc $?"
ncu -i /tmp/op.ncu-rep --page source --csv --print-source sass > /tmp/op-sass.csv 2>&1; python3 scripts/ncu-stalls.py /tmp/op-sass.csv > $OUT/s54/ncu-one_pass-stalls.txt 2>&1; head -30 $OUT/s54/ncu-one_pass-stalls.txt
ncu -i /tmp/op.ncu-rep --page details > $OUT/s54/ncu-details.txt 2>&1; grep -E "Duration|Achieved Occupancy|Registers Per" $OUT/s54/ncu-details.txt
