#!/usr/bin/env bash
# Device call 12 (issue 42): water alone before/after with the bodies' exchange in its own kernel;
# the floating logs with frictionless contacts.
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p12; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name --format=csv,noheader
STEPS=1000 WARMUP=100 RUNS=2 OUT=$L/ab timeout 150 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene dam-break" "--scene bench-655k" "--scene dam-break --scatter fixed-point" > $L/ab.txt 2>&1; tail -8 $L/ab.txt
mkdir -p $P/tests && mv $P/gpu_bodies $P/tests/
timeout 400 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 390 -- logs_float > $L/suite.txt 2>&1
tail -3 $L/suite.txt
grep -h -E "RESULT|panicked" $L/tests/*.log | head -20
tar -czf $OUT/logs.tgz -C $L . && rm -rf $L
