#!/usr/bin/env bash
set -uo pipefail
export PATH=$PATH:/usr/local/cuda/bin
ncu --clock-control none -k 'regex:^p2g$' --launch-skip 100 --launch-count 1 --section SourceCounters \
  --import-source yes --source-folders kernels -o $OUT/src .gpu/bin/mpm bench --scene bench-655k --steps 200 --warmup 0 2>&1 | grep -E "==PROF==|==ERROR|==WARNING"
ncu -i $OUT/src.ncu-rep --page source --csv --print-source cuda 2>&1 | head -12 | cut -c1-160
rm -f $OUT/src.ncu-rep
