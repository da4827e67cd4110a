#!/usr/bin/env bash
# Device call 2 (issue 41): Coulomb friction under the walls' mirror (2dd0208) and the sand columns
# on a floor of the sand's own friction (e02c3ef), against 16c786f (`mpm-old`).
# 1. gpu_solids (the columns at 2.5 and 1.25 mm, both asserted; sand and snow against the CPU),
#    gpu_bodies and gpu_kernels (the bodies' grid update is the renamed own-sums kernel).
# 2. The jelly block sliding on a Coulomb floor under the mirror, on the GPU (scratch test).
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p2; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_* $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=index,name,driver_version --format=csv,noheader
scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --only gpu_solids,gpu_bodies,gpu_kernels --out $OUT/tests -- --nocapture 2>&1 | tail -12
grep -E "runout|Lube" $OUT/tests/gpu_solids.log
BACKEND=cuda MIRROR=on $P/scratch_sand slide --nocapture 2>&1 | grep RESULT
BACKEND=cuda MIRROR=off $P/scratch_sand slide --nocapture 2>&1 | grep RESULT
