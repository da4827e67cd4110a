#!/usr/bin/env bash
# Device call 5 (issue 41): the nodes' own sums read again from the grid after the mirror's channel
# loop instead of taken inside it (the friction and bodies kernels), against 16c786f (`mpm-old`):
# the wave tank, ten floating bodies, the dam break; then gpu_solids and gpu_bodies.
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p5; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_* $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=index,name,driver_version --format=csv,noheader
STEPS=1000 WARMUP=100 RUNS=2 OUT=$OUT/ab scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene wave-tank" \
  "--scene benches/scenes/bench-boxes-bodies.toml" "--scene dam-break" 2>&1 | tail -6
scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --timeout 300 --out $OUT/tests -- --nocapture 2>&1 | tail -6
grep -hE "runout|slows" $OUT/tests/gpu_solids.log
