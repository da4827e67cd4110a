#!/usr/bin/env bash
# Device side, issue 5: every benchmark table, the GPU tests of the timings, and ncu on p2g/g2p.
set -uo pipefail
export PATH=$PATH:/usr/local/cuda/bin
mpm=.gpu/bin/mpm
log=$OUT/device.log
{
  date -u
  nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm,clocks.max.mem --format=csv
  ncu --version | tail -1
  echo "=== tests"
  for t in .gpu/tests/gpu_kernels-* .gpu/tests/gpu_bench-*; do timeout 120 "$t" --nocapture 2>&1 | grep -E "test result|FAILED|panicked|skipped|^\| (total|\*\*total)" ; done
} >"$log" 2>&1
echo "=== main bench"; date -u
timeout 240 $mpm bench --steps 5000 --warmup 200 --cpu-baseline --cpu-steps 1000 --sweep \
  --json $OUT/bench.json 2>&1 | tee $OUT/bench.md
echo "=== variants"; date -u
{
  $mpm bench --scatter fixed-point --steps 1000 --warmup 200
  for b in 64 256; do $mpm bench --scene bench-655k --block-size $b --steps 1000 --warmup 200; done
} >$OUT/variants.md 2>&1
echo "=== frame times: interop vs host copy"; date -u
for s in bench-65k bench-655k; do for d in points spheres; do for t in interop host-copy; do
  printf '%s %s %s: ' $s $d $t
  $mpm render --scene $s --frames 60 --size 1920x1080 --backend cuda --no-images --draw $d --transfer $t 2>&1 | grep "frames via"
done; done; done >$OUT/frame-times.md
echo "=== ncu"; date -u
ncu --clock-control none -k 'regex:^(p2g|g2p)$' --launch-skip 200 --launch-count 2 --set full \
  -o $OUT/ncu-655k $mpm bench --scene bench-655k --steps 200 --warmup 0 >$OUT/ncu.log 2>&1
ncu -i $OUT/ncu-655k.ncu-rep --page details --csv >$OUT/ncu-655k.csv 2>>$OUT/ncu.log
ncu --clock-control none -k 'regex:^(p2g|g2p)$' --launch-skip 20 --launch-count 2 \
  --section SpeedOfLight --section MemoryWorkloadAnalysis --section Occupancy --section LaunchStats \
  --csv --page details $mpm bench --particles 16777216 --grid 295 --steps 30 --warmup 0 >$OUT/ncu-16m.csv 2>>$OUT/ncu.log
date -u; ls -la $OUT
