#!/usr/bin/env bash
# Thickness splats: GL (1ba6235, B) against CUDA at the frame start writing half floats (M).
export MPM_BIN=$PWD/.gpu/bin/mpm PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm B=$PWD/.gpu/bin/mpm-base
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s47
run() { # side scene size
  case $1 in B) bin=$B; env=;; V1) bin=$M; env="MPM_PTX_DIR=$PWD/.gpu/ptx-v1";; M) bin=$M; env=;; esac
  echo "== $1 $2 $3"
  env $env timeout 150 $bin render --scene $2 --frames 90 --size $3 --backend cuda --draw surface --no-images 2>&1 | grep -E "frames via|GPU ms per pass|note|rror"
}
for rep in 1 2; do for size in 1920x1080 960x540; do for side in B M; do run $side dam-break $size; done; done; done | tee $OUT/s47/render.txt
for side in B M; do run $side dam-break-1m 960x540; done | tee -a $OUT/s47/render.txt
for side in B M; do
  timeout 120 ${!side} render --scene dam-break --frames 45 --size 1920x1080 --backend cuda --draw surface --out /tmp/frames-$side > /dev/null 2>&1
  cp /tmp/frames-$side/frame-00045.png $OUT/s47/frame45-$side.png
done
for t in .gpu/tests/gpu_render-* .gpu/tests/headless_render-*; do timeout 120 $t 2>&1 | grep -E "channel|^test |result|panicked"; done | tee $OUT/s47/gpu_render.txt
