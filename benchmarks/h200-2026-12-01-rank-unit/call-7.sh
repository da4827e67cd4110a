#!/usr/bin/env bash
# Call 7 (one H200): 50a7f39, the session's last code: the GPU tests of the ranks, the lifecycle,
# the kernels, the solids, the materials and the renderer.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
timeout 540 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks,gpu_lifecycle,gpu_kernels,gpu_solids,gpu_materials,gpu_render --out /tmp/tests --timeout 535 > $OUT/tests.txt 2>&1
tail -8 $OUT/tests.txt; echo "done at $SECONDS s"
