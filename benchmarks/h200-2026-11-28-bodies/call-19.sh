#!/usr/bin/env bash
# Device call 19 (issue 42): gpu_bodies on the final tree (after the review's place_bodies commit).
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p19; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_bodies $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name --format=csv,noheader
timeout 150 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $OUT/tests --timeout 140 2>&1 | tail -4
grep -h "RESULT dx = 0.0025" $OUT/tests/*.log
