#!/usr/bin/env bash
# Session 29 call 8: the position-based solver's particles gathered into bin order at each binning
# (their volume biases with them), against 3fdee8a (mpm-old, particles in place): gpu_pbmpm and
# gpu_kernels; PLY bytes; pbmpm-1m over 18 s and headless at 960x540 (its first 1.5 s), each side;
# the new build in the window.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
L=/tmp/logs; rm -rf $L /tmp/ply-* /tmp/win-*; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
for t in gpu_pbmpm gpu_kernels; do
  timeout 100 .gpu/tests/$t > $L/test-$t.log 2>&1; echo "== test $t rc $?"; grep -E "^test result|FAILED|RESULT pbmpm GPU bin order" $L/test-$t.log | tail -4
done
timeout 60 bash scripts/ply-identity.sh .gpu/bin/mpm-old .gpu/bin/mpm /tmp/ply-gather --scenes "pbmpm-1m:60 pbmpm-jelly-drop:60" --every 20 > $L/ply-gather.txt 2>&1; echo "== ply rc $?"; grep -v "^  " $L/ply-gather.txt | tail -3
for side in mpm-old mpm; do
  timeout 40 .gpu/bin/$side run --backend cuda --scene pbmpm-1m --frames 1086 > $L/run-pbmpm-1m-$side.log 2>&1; echo "== run $side rc $?: $(grep '^time:' $L/run-pbmpm-1m-$side.log)"
  timeout 30 .gpu/bin/$side render --backend cuda --scene pbmpm-1m --size 960x540 --frames 90 --no-images > $L/render-$side.log 2>&1; echo "== render $side rc $?: $(grep 'frames via' $L/render-$side.log)"
done
rm -rf /tmp/win-new; timeout 70 bash scripts/view-on-gpu.sh --scene pbmpm-1m --frames 600 --fixed-frames 0 --mpm .gpu/bin/mpm --x11 .gpu/x11/root.tar.xz --out /tmp/win-new --timeout 60 -- --max-fps 60 > $L/window-pbmpm-1m.txt 2>&1
echo "== window rc=$?"; grep -E "^viewer: (host|timed|mean|the stepping)" /tmp/win-new/view.log; grep -E "failed|passed" $L/window-pbmpm-1m.txt | tail -1
cp /tmp/win-new/view.log $L/view-pbmpm-1m.log 2>/dev/null; cp /tmp/win-new/window.png $OUT/window-pbmpm-1m.png 2>/dev/null
tar -czf $OUT/logs.tgz -C /tmp logs
