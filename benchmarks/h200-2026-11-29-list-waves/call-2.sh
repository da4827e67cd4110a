#!/usr/bin/env bash
# Session 23 call 2: issue 42's ten-bodies bound (medians); bench-65k per-kernel durations (ncu);
# the list walks' block count (MPM_EXP_LIST_BLOCKS_PER_SM, an experiment build) at 65k, dam break, 16.8M.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm PATH=$PATH:/usr/local/cuda/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
B=benches/scenes
$P/mpm bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1
for r in 1 2 3; do for s in bodies static; do
  timeout 60 $P/mpm bench --scene $B/bench-boxes-$s.toml --steps 1000 > /tmp/boxes-$s-$r.txt 2>&1
  echo "boxes-$s round $r: $(grep -E '^\| \*\*total' /tmp/boxes-$s-$r.txt) $(grep -o 'Wall clock: [0-9.]* ms' /tmp/boxes-$s-$r.txt)"
done; done | tee $OUT/boxes.txt
cp /tmp/boxes-static-1.txt $OUT/boxes-static-1-full.txt
timeout 120 bash scripts/ncu-kernels.sh k65 regex:. --skip 800 --count 40 --metrics gpu__time_duration.sum,launch__grid_size,launch__registers_per_thread --mpm $P/mpm --out /tmp/ncu -- bench --scene bench-65k --steps 400 --warmup 10 > /tmp/ncu.log 2>&1; tail -3 /tmp/ncu.log
cp /tmp/ncu/k65-metrics.csv $OUT/ 2>/dev/null
for b in 32 8 4 2; do printf '#!/bin/sh\nMPM_EXP_LIST_BLOCKS_PER_SM=%s exec %s "$@"\n' $b $P/mpm-exp > $P/mpm-b$b; chmod +x $P/mpm-b$b; done
STEPS=1500 WARMUP=100 RUNS=2 OUT=/tmp/ab1 timeout 150 bash scripts/bench-ab.sh $P/mpm-b32 $P/mpm-b8 "--scene bench-65k" "--scene dam-break" "--scene dam-break-1m" > $OUT/ab-b8.txt 2>&1
STEPS=1500 WARMUP=100 RUNS=2 OUT=/tmp/ab2 timeout 100 bash scripts/bench-ab.sh $P/mpm-b32 $P/mpm-b2 "--scene bench-65k" "--scene dam-break" > $OUT/ab-b2.txt 2>&1
STEPS=200 WARMUP=50 RUNS=1 OUT=/tmp/ab3 timeout 90 bash scripts/bench-ab.sh $P/mpm-b32 $P/mpm-b8 "--particles 16777216 --grid 256" > $OUT/ab-b8-16m.txt 2>&1
grep -h '^| `' $OUT/ab-*.txt
for f in /tmp/ab1/case*-1.log /tmp/ab2/case*-1.log /tmp/ab3/case0-*-1.log; do echo "== $f $(grep -E '^\| (mirror_walls)' $f | awk -F'|' '{print $3, $8}')"; done > $OUT/phases.txt 2>&1; cat $OUT/phases.txt
