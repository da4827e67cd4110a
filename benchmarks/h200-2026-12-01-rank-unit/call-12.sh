#!/usr/bin/env bash
# Call 12 (2 x H200, 206 s of device time left): did this session slow the ranks on two GPUs?
# 314f3ce's binary (`base`) and bb466d1's (`new`) alternated twice, 33.5M particles on two GPUs
# (16.8M a GPU, grid 320), `mpm bench --steps 150 --warmup 30 --gpus 2`.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0
nvidia-smi -L > $OUT/gpus.txt
cd /tmp
for round in 1 2; do for bin in base new; do
  B=$OLDPWD/.gpu/bin/mpm; [ $bin = base ] && B=$OLDPWD/.gpu/bin/mpm-base
  [ $SECONDS -gt 150 ] && { echo "SKIPPED round $round $bin (time)" >> $OUT/ab.txt; continue; }
  timeout 40 $B bench --particles 33554432 --grid 320 --steps 150 --warmup 30 --gpus 2 --json $bin-$round.json > $bin-$round.log 2>&1
  python3 -c "import json; s=json.load(open('$bin-$round.json'))['phases'][0]; print('round $round $bin', s['device'], 'median', round(s['total']['median_ms'],4), 'wall', round(s['wall_ms_per_substep'],4))" >> $OUT/ab.txt 2>&1
done; done
cat $OUT/ab.txt; echo "done at $SECONDS s"
