#!/usr/bin/env bash
# s100 again on the kernels of s101 (count_layers per warp, parked keys spread, halo in memory order).
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
export PATH=$PATH:/usr/local/cuda/bin
S=$OUT/summary.txt
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $S
cd /tmp
for c in "r2 600 700 --particles 33554432 --ranks 2"; do
  set -- $c; name=$1 skip=$2 count=$3; shift 3
  timeout 200 ncu --clock-control none --metrics gpu__time_duration.sum --launch-skip $skip --launch-count $count --csv --page raw \
    $M bench --backend cuda "$@" --grid 256 --steps 150 --warmup 20 > /tmp/$name.csv 2> /tmp/$name.err; echo "== $name ncu rc $?" >> $S
  python3 $G/scripts/kern-sum.py /tmp/$name.csv >> $S 2>&1 || tail -5 /tmp/$name.err >> $S
done
cp /tmp/r2.csv /tmp/c16.csv $OUT/ 2>/dev/null
