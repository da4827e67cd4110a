#!/usr/bin/env bash
# Device call 11 (issue 42): the rigid bodies' GPU tests.
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p11; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name --format=csv,noheader
mkdir -p $P/tests && mv $P/gpu_bodies $P/tests/
timeout 560 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 550 -- logs_float > $L/suite.txt 2>&1
tail -5 $L/suite.txt
grep -h -E "RESULT|apart|differ|panicked|FAIL" $L/tests/*.log | head -40
# Water alone before and after (2ccd986's build against this one).
STEPS=1000 WARMUP=100 RUNS=2 OUT=$L/ab timeout 150 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene dam-break" "--scene bench-655k" "--scene dam-break --scatter fixed-point" > $L/ab.txt 2>&1; tail -10 $L/ab.txt
