#!/usr/bin/env bash
# Device call 2: the elastoviscoplastic Bingham slump at three cells and four plastic viscosities, 8 s each.
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p; [ -x $P/mpm ] || { mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P; }
L=$OUT/logs; mkdir -p $L/sweep
for s in .gpu-exp/sweep/slump-*.toml; do
  n=$(basename $s .toml)
  timeout 60 $P/mpm run --scene $s --frames 480 --backend cuda --export $L/sweep/$n --every 60 > $L/sweep/$n.log 2>&1
  tail -1 $L/sweep/$n.log
done
timeout 60 python3 .gpu-exp/sweep/analyse.py $P $L/sweep > $L/sweep.txt 2>&1; cat $L/sweep.txt
rm -rf $L/sweep/slump-*/
for f in $L/sweep/*.log; do grep -E "^frame +(60|120|240|360|480) " $f > $f.short; rm $f; done
