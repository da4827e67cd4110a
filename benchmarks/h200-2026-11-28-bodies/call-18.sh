#!/usr/bin/env bash
# Device call 18 (issue 42): the backstop's pushes out of a body taken from the body. Water alone
# before/after (one_pass takes the bodies' sums now), the suites, and the floating logs (--ignored).
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p18; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
STEPS=1000 WARMUP=100 RUNS=2 OUT=$L/ab timeout 140 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene dam-break" "--scene bench-655k" "--scene dam-break --scatter fixed-point" > $L/ab.txt 2>&1; tail -6 $L/ab.txt
mkdir -p $P/tests && mv $P/gpu_bodies $P/gpu_kernels $P/gpu_lifecycle $P/tests/
timeout 200 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 190 > $L/suite.txt 2>&1
tail -5 $L/suite.txt
timeout 150 $P/tests/gpu_bodies --ignored > $L/floating.txt 2>&1; grep -E "RESULT|test result|panicked" $L/floating.txt | head -14
tar -czf $OUT/logs.tgz -C $L . && rm -rf $L
