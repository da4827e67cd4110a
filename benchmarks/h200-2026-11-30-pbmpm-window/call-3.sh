#!/usr/bin/env bash
# Session 29 call 3: what the window's extra cost under pbmpm follows (pbmpm-1m steps at 19 ms a frame
# in the window, 10.5 headless): one frame a draw (--fixed-frames 1) against real-time pacing, the
# particles drawn as points against the surface, and the explicit dam-break-1m beside them.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
L=/tmp/logs; rm -rf $L /tmp/win-*; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
win() { # name scene fixed-frames [more viewer args]
  n=$1 s=$2 f=$3; shift 3
  rm -rf /tmp/win-$n; timeout 110 bash scripts/view-on-gpu.sh --scene $s --frames 600 --fixed-frames $f --mpm .gpu/bin/mpm --x11 .gpu/x11/root.tar.xz --out /tmp/win-$n --timeout 100 -- --max-fps 60 "$@" > $L/window-$n.txt 2>&1
  echo "== window $n rc=$?"; grep -E "^viewer: (host|timed|mean|the stepping)" /tmp/win-$n/view.log; grep -E "failed|passed" $L/window-$n.txt | tail -1
  cp /tmp/win-$n/view.log $L/view-$n.log 2>/dev/null; cp /tmp/win-$n/window.png $OUT/window-$n.png 2>/dev/null
}
win pbmpm-1m-fixed1 pbmpm-1m 1
win pbmpm-1m-points pbmpm-1m 0 --draw points
win pbmpm-1m-realtime pbmpm-1m 0
win dam-break-1m-realtime dam-break-1m 0
tar -czf $OUT/logs.tgz -C /tmp logs
