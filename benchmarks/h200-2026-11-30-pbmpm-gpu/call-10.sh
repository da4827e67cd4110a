#!/usr/bin/env bash
# Session 25 call 10: the viewer's pbmpm sliders: gpu_pbmpm whole, and pbmpm-jelly-drop in the window.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
timeout 200 $P/gpu_pbmpm --nocapture > $L/gpu_pbmpm.log 2>&1
grep -E "^test |test result" $L/gpu_pbmpm.log
timeout 150 bash scripts/view-on-gpu.sh --scene pbmpm-jelly-drop --frames 300 --mpm $P/mpm --x11 .gpu/x11/root.tar.xz --out /tmp/win > $L/window.txt 2>&1; echo "window rc=$?"
grep -E "^viewer: (host|timed|mean)" /tmp/win/view.log | head -4; cp /tmp/win/view.log $L/ 2>/dev/null; cp /tmp/win/window.png $OUT/ 2>/dev/null
tar -czf $OUT/logs.tgz -C /tmp logs
