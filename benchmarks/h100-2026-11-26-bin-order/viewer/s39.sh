#!/usr/bin/env bash
# Issue 18's table, 06f9cc2 (mpm-head) against baa8369 (mpm; its kernels are 3efcdf4's), in one call: substeps, fixed/float, headless
# frames, then the viewer in a window (s38.sh).
set -u
export NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm H=$PWD/.gpu/bin/mpm-head
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s39
OUT=$OUT/s39/ab bash scripts/bench-ab.sh $H $M "--scene bench-655k" "--scene bench-65k" "--scene dam-break" "--scene bench-655k --scatter fixed-point" 2>&1 | grep "^| " | tee $OUT/s39/bench.txt
STEPS=300 WARMUP=100 OUT=$OUT/s39/ab16 bash scripts/bench-ab.sh $H $M "--particles 16777216 --grid 256" 2>&1 | grep "^| \`" | tee -a $OUT/s39/bench.txt
rm -rf $OUT/s39/ab $OUT/s39/ab16
for sc in "dam-break --size 960x540" "dam-break-1m --size 960x540" "dam-break --size 1920x1080"; do for v in head new head new; do b=$M; [ $v = head ] && b=$H
  echo "== $v render $sc"; timeout 60 $b render --scene $sc --frames 90 --no-images 2>&1 | grep -E "frames via|GPU ms per pass"; done; done | tee $OUT/s39/render.txt
bash .gpu/scripts/s38.sh 2>&1 | tee $OUT/s39/viewer.txt
