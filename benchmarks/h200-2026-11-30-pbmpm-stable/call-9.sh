#!/usr/bin/env bash
# Session 28 call 7: a 1.1 cm position-based dam break (8 x 2) and the 1.25 cm one under the explicit
# solver: held through 5 s? frame cost (mpm run); each in the window at --max-fps 60, real-time pacing.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0
L=/tmp/logs; rm -rf $L; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
S=benchmarks/h200-2026-11-30-pbmpm-stable/scenes
for s in $S/pb-700k-s8-i2.toml $S/pb-500k-explicit.toml; do
  b=$(basename $s .toml)
  timeout 60 $P/mpm run --backend cuda --scene $s --frames 300 > $L/run-$b.log 2>&1; rc=$?
  echo "== $b rc $rc $(grep -c '^frame' $L/run-$b.log) frames; $(grep '^time:' $L/run-$b.log)"; head -3 $L/run-$b.log | grep -i particles
  grep "^frame" $L/run-$b.log | sed -E 's/.*rho\/rho0=\[[0-9.]+ ([0-9.]+) ([0-9.]+)\].*/\2 \1/' | sort -g | tail -1 | sed 's/^/   densest, its mean: /'
  rm -rf /tmp/win-$b; timeout 100 bash scripts/view-on-gpu.sh --scene $s --frames 600 --fixed-frames 0 --mpm $P/mpm --x11 .gpu/x11/root.tar.xz --out /tmp/win-$b --timeout 90 -- --max-fps 60 > $L/window-$b.txt 2>&1
  echo "== window $b rc=$?"; grep -E "^viewer: (timed|mean|the stepping)" /tmp/win-$b/view.log; grep -E "failed|passed" $L/window-$b.txt | tail -1
  cp /tmp/win-$b/view.log $L/view-$b.log 2>/dev/null; cp /tmp/win-$b/window.png $OUT/window-$b.png 2>/dev/null
done
tar -czf $OUT/logs.tgz -C /tmp logs
