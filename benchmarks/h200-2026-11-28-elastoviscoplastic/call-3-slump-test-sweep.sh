#!/usr/bin/env bash
# Device call 3: the axisymmetric slump (a quarter by the walls' symmetry), 1 L at tau_y = 50 Pa.
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p; [ -x $P/mpm ] || { mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P; }
L=$OUT/logs; mkdir -p $L/axi
for s in .gpu-exp/axi/axi-*.toml; do
  n=$(basename $s .toml)
  timeout 90 $P/mpm run --scene $s --frames 360 --backend cuda --export $L/axi/$n --every 60 > $L/axi/$n.log 2>&1
  tail -1 $L/axi/$n.log
done
timeout 60 python3 .gpu-exp/axi/analyse.py $P $L/axi > $L/axi.txt 2>&1; cat $L/axi.txt
rm -rf $L/axi/axi-*/
for f in $L/axi/*.log; do grep -E "^frame +(60|120|240|360) " $f > $f.short; rm $f; done
