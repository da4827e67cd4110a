#!/usr/bin/env bash
# Session 23 call 1: issue 42's ten-bodies bound on c2d64dc (bodies vs ten static colliders,
# alternating); bench-65k's phase table and per-kernel durations (ncu); EGL: dam-break-1m headless
# frames (eb790ff vs c2d64dc) and gpu_render.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm PATH=$PATH:/usr/local/cuda/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
B=benches/scenes
$P/mpm bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1
for r in 1 2 3; do for s in bodies static; do
  timeout 60 $P/mpm bench --scene $B/bench-boxes-$s.toml --steps 1000 > /tmp/boxes-$s-$r.txt 2>&1
  echo "boxes-$s round $r: $(grep -iE 'median|substep' /tmp/boxes-$s-$r.txt | head -2 | tr '\n' ' ')"
done; done | tee $OUT/boxes.txt
cp /tmp/boxes-bodies-1.txt $OUT/boxes-bodies-1-full.txt
for m in mpm-old mpm; do timeout 60 $P/$m bench --scene bench-65k --steps 2000 --warmup 100 > $OUT/bench65k-$m.txt 2>&1; done
timeout 120 bash scripts/ncu-kernels.sh k65 regex:. --skip 3000 --count 60 --metrics gpu__time_duration.sum --mpm $P/mpm --out /tmp/ncu -- bench --scene bench-65k --steps 400 --warmup 10 > /tmp/ncu.log 2>&1; tail -3 /tmp/ncu.log
cp /tmp/ncu/k65-metrics.csv $OUT/ 2>/dev/null; tail -70 /tmp/ncu.log > $OUT/ncu-k65.txt
for r in 1 2; do for m in mpm-old mpm; do echo "$m round $r: $(timeout 60 $P/$m render --backend cuda --scene dam-break-1m --size 960x540 --frames 90 --no-images 2>&1 | tail -4 | tr '\n' ' ')"; done; done | tee $OUT/render.txt
timeout 200 $P/gpu_render > $OUT/gpu_render.log 2>&1; echo "gpu_render: $(grep 'test result' $OUT/gpu_render.log)"
