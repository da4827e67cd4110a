#!/usr/bin/env bash
# Session 28 call 3: which substeps x iterations hold the position-based dam break through its splash
# (mpm run headless, 5 s at 1 cm, 2.5 s at 0.75 and 0.5 cm), runs side by side (timings not compared).
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
S=benchmarks/h200-2026-11-30-pbmpm-stable/scenes
go() { timeout 280 $P/mpm run --backend cuda --scene $S/$1.toml --frames $2 > $L/run-$1.log 2>&1; echo "rc $?" >> $L/run-$1.log; }
report() { for b in "$@"; do echo "== $b $(tail -1 $L/run-$b.log) $(grep -c '^frame' $L/run-$b.log) frames"; grep "^frame" $L/run-$b.log | awk '{print $0}' | sed -n '$p' | cut -c1-150
  grep "^frame" $L/run-$b.log | sed -E 's/.*rho\/rho0=\[[0-9.]+ [0-9.]+ ([0-9.]+)\].*/\1/' | sort -g | tail -1 | sed 's/^/   max rho\/rho0 over the run: /'; done; }
A="pb-1m-s8-i1 pb-1m-s8-i2 pb-1m-s6-i4 pb-1m-s4-i8 pb-1m-s12-i1 pb-1m-s16-i1 pb-1m-s12-i2"
for b in $A; do go $b 300 & done; wait; report $A
B="pb-3m-s8-i2 pb-3m-s12-i2 pb-3m-s16-i1"
for b in $B; do go $b 150 & done; wait; report $B
C="pb-10m-s16-i2 pb-10m-s16-i4 pb-10m-s32-i1 pb-10m-s24-i2"
for b in $C; do go $b 150 & done; wait; report $C
tar -czf $OUT/logs.tgz -C /tmp logs
