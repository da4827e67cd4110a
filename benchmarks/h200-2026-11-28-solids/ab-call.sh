#!/usr/bin/env bash
# Device call 1: the solids on the GPU (their tests), water-only speed against the build before,
# the three presets' runs.
set -u
cd "$(dirname "$0")/.." || exit 1
P=.gpu-exp/pack; mkdir -p /tmp/p && tar -xJf $P/pack.tar.xz -C /tmp/p
export LD_LIBRARY_PATH=/tmp/gl/usr/lib/x86_64-linux-gnu:${LD_LIBRARY_PATH:-}
export MPM_BIN=/tmp/p/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name,clocks.max.sm --format=csv,noheader | tee $OUT/gpu.txt
L=$OUT/logs; mkdir -p $L
( timeout 420 /tmp/p/gpu_solids --nocapture > $L/gpu_solids.log 2>&1; echo "rc $?" >> $L/gpu_solids.log ) 
tail -30 $L/gpu_solids.log
STEPS=1000 WARMUP=100 RUNS=2 OUT=$L/ab timeout 200 bash scripts/bench-ab.sh /tmp/p/mpm-old /tmp/p/mpm "--scene dam-break" "--scene bench-655k" > $L/ab.txt 2>&1; tail -12 $L/ab.txt
for s in jelly-drop:180:jelly sand-column:120:sand snowball:40:snow; do
  IFS=: read scene frames dir <<< "$s"
  timeout 120 /tmp/p/mpm run --scene $scene --frames $frames --backend cuda --export /tmp/o/$dir --every 20 > $L/run-$scene.log 2>&1; echo "rc $?" >> $L/run-$scene.log
  tail -4 $L/run-$scene.log
done
timeout 100 python3 .gpu-exp/analyse.py .gpu-exp /tmp/o > $L/analyse.txt 2>&1; cat $L/analyse.txt | head -60
tar -czf $OUT/logs.tgz -C $OUT logs
