#!/usr/bin/env bash
# Session 27 call 11: pbmpm-1m in the window (the viewer's own timing), e73e2b3's mpm.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
timeout 150 bash scripts/view-on-gpu.sh --scene pbmpm-1m --frames 400 --mpm $P/mpm --x11 .gpu/x11/root.tar.xz --out /tmp/win > $L/window.txt 2>&1; echo "window rc=$?"
grep -E "^viewer: (host|timed|mean)|FPS|fps" /tmp/win/view.log | head -8; cp /tmp/win/view.log $L/ 2>/dev/null; cp /tmp/win/window.png $OUT/ 2>/dev/null
tar -czf $OUT/logs.tgz -C /tmp logs
