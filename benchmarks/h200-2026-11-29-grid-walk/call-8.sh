#!/usr/bin/env bash
# Session 20 call 8 (issue 47): the grid's float arrays from cuMemAlloc instead of the stream-ordered
# pool (ncu counted every store of the grid update through the L2 compression unit).
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p26; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
M=$P/mpm; export NCCL_NVLS_ENABLE=0
printf '#!/bin/sh\nMPM_GRID_SYNC_ALLOC=1 exec %s "$@"\n' $M > $P/mpm-sync; chmod +x $P/mpm-sync
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
MPM_GRID_SYNC_ALLOC=1 timeout 90 ncu --clock-control none -k regex:grid_update_blocks --launch-skip 30 --launch-count 1 --section SpeedOfLight --section MemoryWorkloadAnalysis $M bench --particles 16777216 --grid 256 --steps 40 --warmup 10 2>&1 | grep -E "Duration|Compression Input|DRAM Through|L2 Hit" | sed "s/^/sync 16m /"
STEPS=200 WARMUP=50 RUNS=1 OUT=/tmp/ab16 bash scripts/bench-ab.sh $M $P/mpm-sync "--particles 16777216 --grid 256" > $OUT/ab16-sync.txt 2>&1
grep '^| `' $OUT/ab16-sync.txt
STEPS=800 WARMUP=100 RUNS=1 OUT=/tmp/ab bash scripts/bench-ab.sh $M $P/mpm-sync "--scene dam-break" "--scene bench-65k" > $OUT/ab-sync.txt 2>&1
grep '^| `' $OUT/ab-sync.txt
