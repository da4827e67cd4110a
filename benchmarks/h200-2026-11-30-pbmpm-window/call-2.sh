#!/usr/bin/env bash
# Session 29 call 2: without the substep's volume bound (reverted after call 1), the position-based
# substep as a CUDA graph against main before it (.gpu/bin/mpm-old): gpu_pbmpm; pbmpm-1m headless
# (960x540, two rounds each) and in the window at --max-fps 60, real-time pacing, old and new.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
L=/tmp/logs; rm -rf $L /tmp/win-*; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
timeout 200 .gpu/tests/gpu_pbmpm > $L/test-gpu_pbmpm.log 2>&1; echo "== test gpu_pbmpm rc $?"; grep -E "^test result|FAILED|RESULT pbmpm GPU graphs" $L/test-gpu_pbmpm.log | tail -4
for round in 1 2; do for side in mpm-old mpm; do
  timeout 60 .gpu/bin/$side render --backend cuda --scene pbmpm-1m --size 960x540 --frames 90 --no-images > $L/render-$side-$round.log 2>&1
  echo "== render $side round $round rc $?: $(grep -E 'ms a frame|per frame' $L/render-$side-$round.log | tail -1)"
done; done
for side in mpm-old mpm; do
  rm -rf /tmp/win-$side; timeout 110 bash scripts/view-on-gpu.sh --scene pbmpm-1m --frames 600 --fixed-frames 0 --mpm .gpu/bin/$side --x11 .gpu/x11/root.tar.xz --out /tmp/win-$side --timeout 100 -- --max-fps 60 > $L/window-$side.txt 2>&1
  echo "== window $side rc=$?"; grep -E "^viewer: (timed|mean|the stepping)" /tmp/win-$side/view.log; grep -E "failed|passed" $L/window-$side.txt | tail -1
  cp /tmp/win-$side/view.log $L/view-$side.log 2>/dev/null; cp /tmp/win-$side/window.png $OUT/window-$side.png 2>/dev/null
done
tar -czf $OUT/logs.tgz -C /tmp logs
