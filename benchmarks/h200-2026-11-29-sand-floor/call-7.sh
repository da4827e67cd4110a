#!/usr/bin/env bash
# Device call 7: the GPU suites at the final tree (ad943cd) that calls 5 and 6 did not run.
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p7; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_* $P/headless_render $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=index,name,driver_version --format=csv,noheader
scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --timeout 300 --out $OUT/tests 2>&1 | tail -12
