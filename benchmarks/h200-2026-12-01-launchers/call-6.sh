#!/usr/bin/env bash
# Call 6 (one H200): ba4ceaf, where the CPU ranks took emitters and sinks and the CUDA ranks refuse
# them by name: gpu_ranks and gpu_lifecycle, and the refusal itself (`fountain` on 2 CUDA ranks).
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
timeout 400 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks,gpu_lifecycle --out /tmp/tests --timeout 395 > $OUT/tests.txt 2>&1
tail -4 $OUT/tests.txt
cd /tmp && timeout 60 $OLDPWD/.gpu/bin/mpm run --backend cuda --scene fountain --ranks 2 --frames 1 > $OUT/refusal.txt 2>&1; echo "rc $?" >> $OUT/refusal.txt; cat $OUT/refusal.txt
echo "done at $SECONDS s"
