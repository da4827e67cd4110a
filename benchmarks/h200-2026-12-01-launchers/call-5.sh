#!/usr/bin/env bash
# Call 5 (one H200): the rest of the GPU tests that spawn scenes (materials, solids, position-based,
# rigid bodies) on the final code. Writes tests.txt and the logs.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
timeout 560 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_materials,gpu_solids,gpu_pbmpm,gpu_bodies --out /tmp/tests --timeout 555 > $OUT/tests.txt 2>&1
tail -12 $OUT/tests.txt
for f in gpu_materials gpu_solids gpu_pbmpm gpu_bodies; do cp /tmp/tests/$f.log $OUT/ 2>/dev/null; done
echo "done at $SECONDS s"
