#!/usr/bin/env bash
# Call 2 (one H200): 0f595a1, the GPU tests the session's changes could touch (the emission and
# bin-order kernels, a solver's places apart from its slots, the checkpoint reader): every GPU test
# executable but gpu_solids, gpu_bodies, gpu_physics and gpu_bench (call 3).
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
timeout 570 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_kernels,gpu_lifecycle,gpu_ranks,gpu_render,gpu_nccl,gpu_materials,gpu_pbmpm --out /tmp/tests --timeout 565 > $OUT/tests.txt 2>&1
tail -12 $OUT/tests.txt; grep -h "finished in" /tmp/tests/*.log >> $OUT/tests.txt
cp /tmp/tests/gpu_ranks.log /tmp/tests/gpu_lifecycle.log $OUT/ 2>/dev/null; echo "done at $SECONDS s"
