#!/usr/bin/env bash
# Two particles a lane (one_pass_float_pairs): kernel tests, sanitizers, A/B against planes and runs.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s66 /tmp/w
for f in runs planes pairs; do printf '#!/bin/sh\nMPM_FLOAT_SCATTER=%s exec %s "$@"\n' $f $M > /tmp/w/mpm-$f; done; chmod +x /tmp/w/*
timeout 150 .gpu/tests/gpu_kernels-* both_float --nocapture 2>&1 | grep -E "Runs|Planes|Pairs|against|test result|panicked" | tee $OUT/s66/test.txt
cases=("--scene dam-break" "--scene bench-655k" "--scene dam-break-1m")
OUT=$OUT/s66/pp RUNS=2 bash scripts/bench-ab.sh /tmp/w/mpm-planes /tmp/w/mpm-pairs "${cases[@]}" 2>&1 | grep "^| " | tee $OUT/s66/ab.txt
OUT=$OUT/s66/pp16 RUNS=1 STEPS=300 WARMUP=100 bash scripts/bench-ab.sh /tmp/w/mpm-planes /tmp/w/mpm-pairs "--particles 16777216 --grid 256" 2>&1 | grep "^| \`" | tee -a $OUT/s66/ab.txt
OUT=$OUT/s66/rp RUNS=2 bash scripts/bench-ab.sh /tmp/w/mpm-runs /tmp/w/mpm-pairs "--scene bench-65k" "--particles 131072" "--particles 262144" "--scene fountain" 2>&1 | grep "^| \`" | tee -a $OUT/s66/ab.txt
OUT=$OUT/s66/p4 RUNS=2 bash scripts/bench-ab.sh /tmp/w/mpm-pairs /tmp/w/mpm-pairs@$G/ptx-p4 "--scene dam-break" "--scene bench-655k" 2>&1 | grep "^| \`" | tee -a $OUT/s66/ab.txt
sc=$PWD/benchmarks/h100-2026-11-25-mirror-in-update/dam-break-crossing.toml
for tool in memcheck racecheck; do MPM_FLOAT_SCATTER=pairs timeout 90 compute-sanitizer --tool $tool --error-exitcode 9 $M run --backend cuda --scene $sc --frames 2 > /tmp/san.log 2>&1; echo "$tool crossing float pairs: rc=$? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/san.log)"; done | tee $OUT/s66/sanitize.txt
MPM_FLOAT_SCATTER=pairs timeout 240 .gpu/tests/gpu_kernels-* 2>&1 | grep -E "^test result|FAILED|panicked" | tee $OUT/s66/tests-pairs.txt
