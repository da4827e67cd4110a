#!/usr/bin/env bash
# Device side, issue 5, second pass: block sizes over the same window, ncu on the other kernels
# (with atomic throughput), and the compute-sanitizer recipe.
set -uo pipefail
export PATH=$PATH:/usr/local/cuda/bin
mpm=.gpu/bin/mpm
for b in 64 128 256; do
  $mpm bench --scene bench-655k --block-size $b --steps 5000 --warmup 200 | grep -E "^###|total|p2g |g2p "
done 2>&1 | tee $OUT/blocks.md
red=lts__t_sectors_op_red.sum,lts__t_sectors_op_red.sum.per_second,lts__t_requests_op_red.sum,lts__t_sectors_op_atom.sum,lts__t_sectors_op_red.avg.pct_of_peak_sustained_elapsed,smsp__inst_executed_op_global_red.sum
secs="--section SpeedOfLight --section MemoryWorkloadAnalysis --section Occupancy --section LaunchStats --section WarpStateStats --section ComputeWorkloadAnalysis"
ncu --clock-control none -k 'regex:^(p2g_init|p2g|grid_update|g2p)$' --launch-skip 400 --launch-count 4 $secs \
  --metrics $red --csv --page details $mpm bench --scene bench-655k --steps 150 --warmup 0 >$OUT/ncu-kernels.csv 2>$OUT/ncu2.log
ncu --clock-control none -k 'regex:^(sort_count|scan_tiles|scan_add|sort_scatter)$' --launch-skip 20 --launch-count 6 $secs \
  --csv --page details $mpm bench --scene bench-655k --steps 100 --warmup 0 >$OUT/ncu-sort.csv 2>>$OUT/ncu2.log
compute-sanitizer --tool memcheck --error-exitcode 9 $mpm bench --scene bench-65k --steps 20 --warmup 0 >$OUT/memcheck.log 2>&1
echo "memcheck exit $?" | tee -a $OUT/memcheck.log
tail -3 $OUT/memcheck.log
