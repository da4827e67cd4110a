#!/usr/bin/env bash
# Call 8 (one H200): a479c3b, a resumed run's whole-or-share choice in the backend: gpu_ranks and
# gpu_lifecycle, and `fountain` on 3 ranks of one GPU against one GPU (PLY bytes at frame 90).
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
timeout 200 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks,gpu_lifecycle --out /tmp/tests --timeout 195 > $OUT/tests.txt 2>&1
tail -4 $OUT/tests.txt; echo "done at $SECONDS s"
M=$PWD/.gpu/bin/mpm; F=/tmp/fountain; mkdir -p $F; cd $F
for how in one ranks3; do
  extra=""; [ $how = ranks3 ] && extra="--ranks 3"
  timeout 100 $M run --backend cuda --scatter fixed-point --scene fountain --frames 90 --export $how --every 90 $extra > $how.log 2>&1
  echo "$how rc $?: $(grep '^frame' $how.log | tail -1)" >> $OUT/fountain.txt
done
cmp -s one/frame_000090.ply ranks3/frame_000090.ply && echo "ranks3 frame 90: one GPU's bytes" >> $OUT/fountain.txt || echo "ranks3 frame 90: DIFFERS" >> $OUT/fountain.txt
cat $OUT/fountain.txt
