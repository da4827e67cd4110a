#!/usr/bin/env bash
# Device call 6: the floating and sinking blocks averaged over the last 1.5 s of 3 (was the last
# half second of 2), twice, float scatter.
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p6; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_* $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=index,name,driver_version --format=csv,noheader
for r in 1 2; do
  scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --only gpu_solids --out $OUT/tests-$r -- blocks_float --nocapture 2>&1 | tail -2
  grep -hE "under \(" $OUT/tests-$r/gpu_solids.log
done
