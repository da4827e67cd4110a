#!/usr/bin/env bash
# Device call 14 (issue 42): the suites that run colliders on the GPU, and the bodies'; water alone
# before/after again (3 rounds).
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p14; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name --format=csv,noheader
STEPS=1000 WARMUP=100 RUNS=3 OUT=$L/ab timeout 200 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene dam-break" "--scene bench-655k" "--scene dam-break --scatter fixed-point" > $L/ab.txt 2>&1; tail -7 $L/ab.txt
mkdir -p $P/tests && mv $P/gpu_bodies $P/gpu_kernels $P/gpu_lifecycle $P/tests/
timeout 360 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 350 > $L/suite.txt 2>&1
tail -6 $L/suite.txt
grep -h -E "apart|panicked" $L/tests/gpu_bodies.log | head -8
tar -czf $OUT/logs.tgz -C $L . && rm -rf $L
