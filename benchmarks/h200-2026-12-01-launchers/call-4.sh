#!/usr/bin/env bash
# Call 4 (asked for 2 x H200, run on one H200: no two-GPU host was lent then): the final code's GPU tests that the spawn's rewrite (Scene::each_spawned) and
# the ranks' new start could touch: the kernels against the CPU reference, the lifecycle, the bench,
# the physics check, the renderer, NCCL and every ranks test. Writes tests.txt and the logs.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
timeout 560 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks_on_gpus,gpu_ranks,gpu_nccl,gpu_nccl_pair,gpu_kernels,gpu_lifecycle,gpu_bench,gpu_physics,gpu_render --out /tmp/tests --timeout 555 > $OUT/tests.txt 2>&1
tail -12 $OUT/tests.txt
for f in gpu_ranks_on_gpus gpu_kernels gpu_lifecycle gpu_render gpu_ranks; do cp /tmp/tests/$f.log $OUT/ 2>/dev/null; done
echo "done at $SECONDS s"
