#!/usr/bin/env bash
# ncu of grid_update_blocks: main's kernel (head) against v1 (a barrier every iteration), at 16.8M and bench-65k.
export NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm
mkdir -p $OUT/ncu
for k in head v1; do for args in "--particles 16777216 --grid 256 --steps 12 --warmup 4" "--scene bench-65k --steps 40 --warmup 10"; do
  tag=$k-$(echo $args | cut -d' ' -f2)
  MPM_PTX_DIR=$PWD/.gpu/ptx-$k timeout 150 ncu --clock-control none -k regex:"grid_update_blocks" --launch-skip 9 --launch-count 1 --section SpeedOfLight --section Occupancy --section LaunchStats --section WarpStateStats --section MemoryWorkloadAnalysis --section SchedulerStats --csv $M bench $args > $OUT/ncu/$tag.csv 2>&1
  echo "== $tag"; grep -E "\"Duration|Registers Per|Achieved Occupancy|Memory Throughput|DRAM Throughput|L2 Hit Rate|L1/TEX Hit|Warp Cycles Per Issued|Stall|Eligible Warps|Issued Warp" $OUT/ncu/$tag.csv | awk -F'","' '{print $13": "$15}' | head -24
done; done
tar czf $OUT/ncu.tgz -C $OUT ncu
