#!/usr/bin/env bash
# one_pass_float without barriers (the run heads list the node blocks from the global marks; PTX in
# .gpu/ptx-nobar) against acdf1e2's kernels, same binary; then the GPU kernel, physics and lifecycle
# tests on the new PTX.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm N=$PWD/.gpu/ptx-nobar
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s50
OUT=$OUT/s50/ab bash scripts/bench-ab.sh $M $M@$N "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" 2>&1 | grep "^|" | tee $OUT/s50/bench.txt
STEPS=300 WARMUP=100 OUT=$OUT/s50/ab16 bash scripts/bench-ab.sh $M $M@$N "--particles 16777216 --grid 256" 2>&1 | grep "^|" | tail -1 | tee -a $OUT/s50/bench.txt
rm -rf $OUT/s50/ab $OUT/s50/ab16
for sc in "dam-break --size 960x540" "dam-break-1m --size 960x540"; do for side in old new; do
  if [ $side = new ]; then export MPM_PTX_DIR=$N; else unset MPM_PTX_DIR; fi
  echo "== $side render $sc"; timeout 90 $M render --scene $sc --frames 90 --no-images 2>&1 | grep -E "frames via"; done; done | tee $OUT/s50/render.txt
export MPM_PTX_DIR=$N
bash .gpu/run true
for t in .gpu/tests/gpu_kernels-* .gpu/tests/gpu_physics-* .gpu/tests/gpu_lifecycle-* .gpu/tests/gpu_render-*; do timeout 200 $t 2>&1 | grep -E "^test result|FAILED|panicked|PTX|ptx" | head -5; done | tee $OUT/s50/tests.txt
