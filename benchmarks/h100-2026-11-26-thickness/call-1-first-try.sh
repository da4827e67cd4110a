#!/usr/bin/env bash
# The surface's thickness splats by CUDA (working tree, mpm) against GL's blending (1ba6235, mpm-base):
# render timings at 1080p and 960x540, frame 45 of each, the new test, then the whole suite.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm B=$PWD/.gpu/bin/mpm-base
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s44
for size in 1920x1080 960x540; do for rep in 1 2; do for side in B M; do
  echo "== $side $size rep $rep"
  timeout 120 ${!side} render --scene dam-break --frames 90 --size $size --backend cuda --draw surface --no-images 2>&1 | grep -E "frames via|GPU ms per pass|note"
done; done; done | tee $OUT/s44/render.txt
for side in B M; do
  echo "== $side dam-break-1m 960x540"
  timeout 150 ${!side} render --scene dam-break-1m --frames 90 --size 960x540 --backend cuda --draw surface --no-images 2>&1 | grep -E "frames via|GPU ms per pass|note"
done | tee -a $OUT/s44/render.txt
for side in B M; do
  timeout 120 ${!side} render --scene dam-break --frames 45 --size 1920x1080 --backend cuda --draw surface --out /tmp/frames-$side > /dev/null 2>&1
  cp /tmp/frames-$side/frame-00045.png $OUT/s44/frame45-$side.png
done
timeout 120 .gpu/tests/gpu_render-* 2>&1 | tail -40 | tee $OUT/s44/gpu_render.txt
timeout 300 bash .gpu/tests/all > $OUT/s44/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s44/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s44/tests.log | head -20
