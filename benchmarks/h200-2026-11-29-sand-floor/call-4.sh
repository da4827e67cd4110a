#!/usr/bin/env bash
# Device call 4 (issue 41): the Coulomb colliders under the mirror on a kernel of their own,
# grid_update_blocks_friction (without the bodies' exchange, 14 blocks an SM), against 16c786f
# (`mpm-old`): the wave tank (a Coulomb beach at the wall), the dam break and bench-655k; then
# gpu_solids and the GPU suites the colliders' grid update touches.
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p4; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_* $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=index,name,driver_version --format=csv,noheader
STEPS=1000 WARMUP=100 RUNS=2 OUT=$OUT/ab scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene wave-tank" "--scene dam-break" \
  "--scene bench-655k" 2>&1 | tail -6
scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --timeout 240 --out $OUT/tests -- --nocapture 2>&1 | tail -12
grep -hE "runout|slows" $OUT/tests/gpu_solids.log
