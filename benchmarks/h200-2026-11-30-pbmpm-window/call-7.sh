#!/usr/bin/env bash
# Session 29 call 7: pbmpm_volume_targets walked in bin order (was slot order) against efd1e66
# (mpm-old): PLY bytes (the kernel's per-particle arithmetic is unchanged), gpu_pbmpm, pbmpm-1m over
# 18 s headless each side, ncu of the new build 10 s in, and the new build in the window.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
L=/tmp/logs; rm -rf $L /tmp/ply-* /tmp/win-*; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
timeout 120 .gpu/tests/gpu_pbmpm > $L/test-gpu_pbmpm.log 2>&1; echo "== test gpu_pbmpm rc $?"; grep -E "^test result|FAILED" $L/test-gpu_pbmpm.log | tail -3
timeout 90 bash scripts/ply-identity.sh .gpu/bin/mpm-old .gpu/bin/mpm /tmp/ply-order --scenes "pbmpm-1m:60 pbmpm-jelly-drop:60" --every 20 > $L/ply-order.txt 2>&1; echo "== ply rc $?"; grep -v "^  " $L/ply-order.txt | tail -3
for side in mpm-old mpm; do
  timeout 60 .gpu/bin/$side run --backend cuda --scene pbmpm-1m --frames 1086 > $L/run-pbmpm-1m-$side.log 2>&1; echo "== run $side rc $?: $(grep '^time:' $L/run-pbmpm-1m-$side.log)"
done
timeout 100 bash scripts/ncu-kernels.sh pbmpm-1m-late "regex:.*" --skip 100000 --count 400 --metrics gpu__time_duration.sum --out $L --timeout 90 -- run --backend cuda --scene pbmpm-1m --frames 800 > $L/ncu-late.txt 2>&1; echo "== ncu rc $?"
rm -rf /tmp/win-new; MPM_CUDA_GRAPHS=1 timeout 90 bash scripts/view-on-gpu.sh --scene pbmpm-1m --frames 600 --fixed-frames 0 --mpm .gpu/bin/mpm --x11 .gpu/x11/root.tar.xz --out /tmp/win-new --timeout 80 -- --max-fps 60 > $L/window-pbmpm-1m.txt 2>&1
echo "== window rc=$?"; grep -E "^viewer: (host|timed|mean|the stepping)" /tmp/win-new/view.log; grep -E "failed|passed" $L/window-pbmpm-1m.txt | tail -1
cp /tmp/win-new/view.log $L/view-pbmpm-1m.log 2>/dev/null; cp /tmp/win-new/window.png $OUT/window-pbmpm-1m.png 2>/dev/null
tar -czf $OUT/logs.tgz -C /tmp logs
