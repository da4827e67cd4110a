#!/usr/bin/env bash
# Call 5 (one H200): 1265d15, the final build (the lifecycle on the ranks moved to its own file, the
# Start check shared): gpu_ranks, gpu_lifecycle and gpu_kernels again, and `fountain` on 4 ranks of
# one GPU to frame 90 against one GPU (PLY bytes and counts).
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
timeout 300 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks,gpu_lifecycle,gpu_kernels --out /tmp/tests --timeout 295 > $OUT/tests.txt 2>&1
tail -5 $OUT/tests.txt
M=$PWD/.gpu/bin/mpm; F=/tmp/fountain; mkdir -p $F; cd $F
for how in one ranks4; do
  extra=""; [ $how = ranks4 ] && extra="--ranks 4"
  timeout 100 $M run --backend cuda --scatter fixed-point --scene fountain --frames 90 --export $how --every 90 $extra > $how.log 2>&1
  echo "$how rc $?: $(grep '^frame' $how.log | tail -1)" >> $OUT/fountain.txt
done
cmp -s one/frame_000090.ply ranks4/frame_000090.ply && echo "ranks4 frame 90: one GPU's bytes" >> $OUT/fountain.txt || echo "ranks4 frame 90: DIFFERS" >> $OUT/fountain.txt
cat $OUT/fountain.txt; echo "done at $SECONDS s"
