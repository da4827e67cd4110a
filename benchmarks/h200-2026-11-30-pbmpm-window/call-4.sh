#!/usr/bin/env bash
# Session 29 call 4: the stepping paced substep by substep under the viewer's GPU gate where a stretch
# is a whole frame (the position-based solver's fixed step), in the window at --max-fps 60, real-time
# pacing: main before this session (mpm-old), with the pbmpm graphs only (mpm-graphs), and paced (mpm);
# the explicit dam-break-1m (a CFL stretch of 4 substeps: not paced) old and new beside them.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
L=/tmp/logs; rm -rf $L /tmp/win-*; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
win() { # name binary scene
  n=$1 b=$2 s=$3
  rm -rf /tmp/win-$n; timeout 110 bash scripts/view-on-gpu.sh --scene $s --frames 600 --fixed-frames 0 --mpm .gpu/bin/$b --x11 .gpu/x11/root.tar.xz --out /tmp/win-$n --timeout 100 -- --max-fps 60 > $L/window-$n.txt 2>&1
  echo "== window $n rc=$?"; grep -E "^viewer: (host|timed|mean|the stepping)" /tmp/win-$n/view.log; grep -E "failed|passed" $L/window-$n.txt | tail -1
  cp /tmp/win-$n/view.log $L/view-$n.log 2>/dev/null; cp /tmp/win-$n/window.png $OUT/window-$n.png 2>/dev/null
}
win pbmpm-1m-paced mpm pbmpm-1m
win pbmpm-1m-old mpm-old pbmpm-1m
win pbmpm-1m-graphs mpm-graphs pbmpm-1m
win dam-break-1m-new mpm dam-break-1m
win dam-break-1m-old mpm-old dam-break-1m
win pb-700k-paced mpm .gpu/scenes/pb-700k-s8-i2.toml
win pb-3m-paced mpm .gpu/scenes/pb-3m-s12-i2.toml
tar -czf $OUT/logs.tgz -C /tmp logs
