#!/usr/bin/env bash
# Session 25 call 8: the final build: the CPU comparison once more; the water scenes against the build
# before (mpm-old); the position-based benches (1M, 10M; 1, 2, 4 iterations) beside the explicit
# solver; headless frames; pbmpm-1m in the window.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
timeout 100 $P/gpu_pbmpm --nocapture every_law > $L/gpu_pbmpm.log 2>&1
echo "gpu_pbmpm every_law: $(grep 'test result' $L/gpu_pbmpm.log)"; grep -E "above 1e-3\)" $L/gpu_pbmpm.log | grep -v "(0 particles" | cut -c1-200 | tail -4
for m in mpm-old mpm; do $P/$m bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1; done
STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab1 timeout 200 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene bench-65k" "--scene dam-break" "--scene dam-break-1m" > $L/ab.txt 2>&1
grep '^| `' $L/ab.txt
S=.gpu-exp/scenes
for s in pbmpm-dam-break pbmpm-jelly-drop $S/pb-1m-s4-i1.toml $S/pb-1m-s4-i2.toml pbmpm-1m $S/pb-10m-s8-i1.toml $S/pb-10m-s8-i2.toml $S/pb-10m-explicit.toml; do
  timeout 60 $P/mpm bench --scene $s --steps 100 --warmup 10 > $L/bench-$(basename $s .toml).txt 2>&1
  echo "== $s rc $? $(grep -o 'Wall clock: [0-9.]* ms' $L/bench-$(basename $s .toml).txt) $(grep '^| \*\*total' $L/bench-$(basename $s .toml).txt)"
done
for s in pbmpm-1m pbmpm-jelly-drop dam-break-1m; do
  timeout 60 $P/mpm render --backend cuda --scene $s --size 960x540 --frames 90 --no-images > $L/render-$s.txt 2>&1; echo "== render $s: $(grep 'frames via' $L/render-$s.txt)"
done
timeout 120 bash scripts/view-on-gpu.sh --scene pbmpm-1m --frames 400 --mpm $P/mpm --x11 .gpu/x11/root.tar.xz --out /tmp/win > $L/window.txt 2>&1; echo "window rc=$?"
grep -E "^viewer: (host|timed|mean)|FPS|fps" /tmp/win/view.log | head -8; cp /tmp/win/view.log $L/ 2>/dev/null; cp /tmp/win/window.png $OUT/ 2>/dev/null
tar -czf $OUT/logs.tgz -C /tmp logs
