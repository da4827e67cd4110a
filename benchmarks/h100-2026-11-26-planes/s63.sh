#!/usr/bin/env bash
# ncu of grid_update_blocks at the dam break and bench-655k (d55b8d3).
export MPM_BIN=$PWD/.gpu/bin/mpm PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
mkdir -p $OUT/s63
for sc in dam-break bench-655k; do
timeout 120 ncu --clock-control none --set full --import-source yes -k regex:grid_update_blocks --launch-skip 300 --launch-count 1 -o /tmp/gu-$sc $M bench --scene $sc --steps 400 --warmup 10 > /tmp/ncu.log 2>&1; echo "ncu $sc rc $?"
ncu -i /tmp/gu-$sc.ncu-rep --page source --csv --print-source sass > /tmp/gu-sass.csv 2>&1; python3 scripts/ncu-stalls.py /tmp/gu-sass.csv > $OUT/s63/ncu-gu-$sc-stalls.txt 2>&1; head -28 $OUT/s63/ncu-gu-$sc-stalls.txt
ncu -i /tmp/gu-$sc.ncu-rep --page details > $OUT/s63/ncu-gu-$sc.txt 2>&1; grep -E "grid_update_blocks|Duration|Achieved Occupancy|Registers Per|Grid Size|Memory Throughput|DRAM Throughput|Elapsed Cycles|Waves Per SM|Block Limit" $OUT/s63/ncu-gu-$sc.txt | head -14
done
