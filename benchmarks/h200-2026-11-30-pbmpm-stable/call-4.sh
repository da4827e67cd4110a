#!/usr/bin/env bash
# Session 28 call 4: gpu_pbmpm with the preset's 5 s run; particles against frame cost for the
# position-based settings that hold through the splash and the explicit solver on the same scenes
# (mpm run, 150 frames, the substeps' own CUDA-event timing); headless frames; the window at
# --max-fps 60 with real-time pacing.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
S=benchmarks/h200-2026-11-30-pbmpm-stable/scenes
timeout 240 $P/gpu_pbmpm --nocapture > $L/gpu_pbmpm.log 2>&1
echo "gpu_pbmpm: $(grep 'test result' $L/gpu_pbmpm.log)"; grep -E "^test .*(FAILED|ignored)|panicked|RESULT pbmpm GPU pbmpm-1m" $L/gpu_pbmpm.log | head
for s in pbmpm-1m $S/pb-1m-s8-i4.toml $S/pb-1m-s12-i2.toml dam-break-1m $S/pb-3m-s12-i2.toml $S/pb-3m-explicit.toml $S/pb-10m-s24-i2.toml $S/pb-10m-s16-i4.toml $S/pb-10m-explicit.toml; do
  b=$(basename $s .toml)
  timeout 120 $P/mpm run --backend cuda --scene $s --frames 150 > $L/run-$b.log 2>&1; rc=$?
  echo "== $b rc $rc $(grep -c '^frame' $L/run-$b.log) frames; $(grep '^time:' $L/run-$b.log)"
  grep "^frame" $L/run-$b.log | sed -E 's/.*rho\/rho0=\[[0-9.]+ ([0-9.]+) ([0-9.]+)\].*/\2 \1/' | sort -g | tail -1 | sed 's/^/   densest, its mean: /'
done
for s in pbmpm-1m dam-break-1m; do
  timeout 60 $P/mpm render --backend cuda --scene $s --size 960x540 --frames 90 --no-images > $L/render-$s.txt 2>&1; echo "== render $s: $(grep 'frames via' $L/render-$s.txt)"
done
for s in pbmpm-1m $S/pb-10m-s24-i2.toml; do
  b=$(basename $s .toml)
  timeout 60 $P/mpm bench --scene $s --steps 48 --warmup 8 > $L/bench-$b.txt 2>&1; echo "== bench $b rc $? $(grep -o 'Wall clock: [0-9.]* ms' $L/bench-$b.txt)"; grep "^| " $L/bench-$b.txt | cut -d'|' -f2-3 | tail -6
done
run_view() { # name scene frames extra...
  local name=$1 scene=$2 frames=$3; shift 3
  timeout 200 bash scripts/view-on-gpu.sh --scene $scene --frames $frames --fixed-frames 0 --mpm $P/mpm --x11 .gpu/x11/root.tar.xz --out /tmp/win-$name --timeout 180 -- "$@" > $L/window-$name.txt 2>&1
  echo "== window $name rc=$?"; grep -E "^viewer: (timed|mean|the stepping)" /tmp/win-$name/view.log; grep -E "failed|passed" $L/window-$name.txt | tail -2
  cp /tmp/win-$name/view.log $L/view-$name.log 2>/dev/null; cp /tmp/win-$name/window.png $OUT/window-$name.png 2>/dev/null
}
run_view pbmpm-1m pbmpm-1m 600 --max-fps 60
run_view dam-break-1m dam-break-1m 600 --max-fps 60
run_view pb-3m-s12-i2 $S/pb-3m-s12-i2.toml 300 --max-fps 60
run_view pb-10m-s24-i2 $S/pb-10m-s24-i2.toml 150 --max-fps 60
run_view pbmpm-1m-uncapped pbmpm-1m 600
tar -czf $OUT/logs.tgz -C /tmp logs
