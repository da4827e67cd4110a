#!/usr/bin/env bash
# Call 6 (one H200): 22fcd43, the backend's starting particles shared (checkpoints resumed through
# it): gpu_ranks and gpu_lifecycle.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
timeout 200 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks,gpu_lifecycle --out /tmp/tests --timeout 195 > $OUT/tests.txt 2>&1
tail -4 $OUT/tests.txt; echo "done at $SECONDS s"
