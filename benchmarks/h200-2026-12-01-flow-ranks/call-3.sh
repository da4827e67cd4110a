#!/usr/bin/env bash
# Call 3 (one H200): 0f595a1, gpu_solids, gpu_bodies, gpu_physics and gpu_bench.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
timeout 570 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_solids,gpu_bodies,gpu_physics,gpu_bench --out /tmp/tests --timeout 565 > $OUT/tests.txt 2>&1
tail -4 $OUT/tests.txt; grep -h "finished in" /tmp/tests/*.log >> $OUT/tests.txt; echo "done at $SECONDS s"
