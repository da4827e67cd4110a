#!/usr/bin/env bash
# Call 10 (one H200): the working tree after 48b3591: the rank-by-rank read in pieces of 262,144
# places (DeviceParticles::place_live_into). gpu_ranks; and dam-break-1m (1M particles: about
# 500,000 places a rank on 2 ranks, two pieces each) on 2 and 3 ranks against one GPU, PLY bytes at
# frame 3 in fixed point.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
M=$PWD/.gpu/bin/mpm
timeout 120 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks --out /tmp/tests --timeout 115 > $OUT/tests.txt 2>&1
tail -2 $OUT/tests.txt
S=/tmp/reads; mkdir -p $S; cd $S
for how in one ranks2 ranks3; do
  extra=""; [ $how = ranks2 ] && extra="--ranks 2"; [ $how = ranks3 ] && extra="--ranks 3"
  timeout 100 $M run --backend cuda --scatter fixed-point --scene dam-break-1m --frames 3 --export d-$how --every 3 $extra > d-$how.log 2>&1
  echo "$how rc $?: $(grep '^frame' d-$how.log | tail -1)" >> $OUT/reads.txt
  [ $how = one ] || { cmp -s d-one/frame_000003.ply d-$how/frame_000003.ply && echo "dam-break-1m $how frame 3: one GPU's bytes" >> $OUT/reads.txt || echo "dam-break-1m $how frame 3: DIFFERS" >> $OUT/reads.txt; }
done
cat $OUT/reads.txt; echo "done at $SECONDS s"
