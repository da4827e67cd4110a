#!/usr/bin/env bash
# Session 28 call 2: how long the position-based scenes run before an error (the window's runs all
# stopped at 1.783 s simulated): mpm run headless, the last lines of each.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
S=benchmarks/h200-2026-11-30-pbmpm-stable/scenes
go() { # scene frames
  local b=$(basename $1 .toml); local t0=$(date +%s.%N)
  timeout 100 $P/mpm run --backend cuda --scene $1 --frames $2 > $L/run-$b.log 2>&1; local rc=$?
  echo "== $b frames $2 rc $rc $(echo "$(date +%s.%N) - $t0" | bc) s"; grep -iE "error|overflow|diverg|collaps" $L/run-$b.log | head -3; tail -2 $L/run-$b.log
}
go pbmpm-1m 300
go $S/pb-1m-s8-i4.toml 300
go $S/pb-1m-s4-i1.toml 300
go pbmpm-dam-break 300
go $S/pb-10m-s8-i1.toml 60
go $S/pb-10m-s16-i1.toml 60
go $S/pb-10m-s8-i4.toml 30
tar -czf $OUT/logs.tgz -C /tmp logs
