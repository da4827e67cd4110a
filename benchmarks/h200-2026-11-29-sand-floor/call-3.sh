#!/usr/bin/env bash
# Device call 3 (issue 41): gpu_solids with the sand columns on a Coulomb floor without the mirror
# and the sliding block under it; gpu_kernels (the binned refusal now only where a Coulomb collider
# reaches the mirror); the floating block again (float scatter: run to run); then water's and ten
# floating bodies' substeps, 16c786f (`mpm-old`) against this tree (scripts/bench-ab.sh).
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p3; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_* $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=index,name,driver_version --format=csv,noheader
scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --only gpu_solids,gpu_kernels --out $OUT/tests -- --nocapture 2>&1 | tail -8
grep -hE "runout|Lube|slows|under \(|follow|position error" $OUT/tests/gpu_solids.log
scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --only gpu_solids --out $OUT/tests2 -- blocks_float --nocapture 2>&1 | tail -3
grep -hE "under \(" $OUT/tests2/gpu_solids.log
STEPS=1000 WARMUP=100 RUNS=2 OUT=$OUT/ab scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene bench-65k" "--scene dam-break" \
  "--scene bench-655k" "--scene dam-break --scatter fixed-point" "--scene benches/scenes/bench-boxes-bodies.toml" "--scene wave-tank" 2>&1 | tail -12
