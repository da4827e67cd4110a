#!/usr/bin/env bash
# Call 6: the final code (a20984a) on two H200s: the GPU tests not run on it in calls 4 and 5 (the
# ranks and NCCL, materials, solids, and gpu_bodies on the second GPU beside them).
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
(CUDA_VISIBLE_DEVICES=1 timeout 330 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_bodies --out /tmp/tests-bodies --timeout 320 > $OUT/tests-bodies.txt 2>&1) &
timeout 300 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks,gpu_ranks_on_gpus,gpu_nccl,gpu_nccl_pair,gpu_materials,gpu_solids --out /tmp/tests --timeout 200 > $OUT/tests.txt 2>&1
wait
cat $OUT/tests.txt $OUT/tests-bodies.txt
