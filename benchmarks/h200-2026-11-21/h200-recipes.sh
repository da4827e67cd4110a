#!/usr/bin/env bash
# Device side: check the README's profiling recipes and the cargo bench target.
set -uo pipefail
export PATH=$PATH:/usr/local/cuda/bin
mpm=.gpu/bin/mpm
b=$(ls .gpu/benches/gpu_step-* | head -1)
$b --bench 1000 2>&1 | grep -E "^###|total|skipped" | tee $OUT/recipes.log
ncu --clock-control none --nvtx --nvtx-include 'substep/p2g/' --launch-skip 100 --launch-count 1 \
  --section SpeedOfLight -o $OUT/nvtx-p2g $mpm bench --scene bench-655k --steps 200 --warmup 0 2>&1 | grep -E "==PROF==|==ERROR|==WARNING" | tee -a $OUT/recipes.log
ncu -i $OUT/nvtx-p2g.ncu-rep --page details --csv 2>&1 | grep -E "Duration|Kernel Name" | head -3 | tee -a $OUT/recipes.log
ncu --clock-control none -k 'regex:^(p2g|g2p)$' --launch-skip 200 --launch-count 2 --section SpeedOfLight --section SourceCounters \
  --import-source yes -o $OUT/src $mpm bench --scene bench-655k --steps 200 --warmup 0 2>&1 | grep -E "==PROF==|==ERROR" | tee -a $OUT/recipes.log
ncu -i $OUT/src.ncu-rep --page source --csv --print-source cuda 2>&1 | head -5 | cut -c1-200 | tee -a $OUT/recipes.log
timeout 200 compute-sanitizer --tool racecheck --error-exitcode 9 $mpm bench --scene bench-65k --steps 20 --warmup 0 2>&1 | tail -2 | tee -a $OUT/recipes.log
rm -f $OUT/*.ncu-rep
