#!/usr/bin/env bash
# Call 5: the tiled volume scatter: the GPU checks of liquids and ranks, water's speed and the liquids' cost, oil-on-water.
set -u
rm -rf .gpu; mkdir -p .gpu && tar xJf .gpu-pack9/pack.tar.xz -C .gpu
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/device.txt
timeout 300 bash .gpu/run bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --out /tmp/g --timeout 250 --only gpu_materials,gpu_ranks,gpu_kernels,gpu_physics 2>&1 | tail -8
STEPS=2000 WARMUP=200 RUNS=2 OUT=/tmp/ab bash .gpu/run bash scripts/bench-ab.sh .gpu/before/mpm .gpu/bin/mpm \
  "--scene bench-655k" "--scene dam-break" "--scene bench-655k --pipeline binned" "--scene benches/scenes/bench-655k-power-law.toml" \
  "--scene benches/scenes/bench-655k-two-liquids.toml" "--scene benches/scenes/bench-655k-two-liquids.toml --pipeline binned" \
  "--scene benches/scenes/bench-655k-two-liquids.toml --scatter fixed-point" \
  > /tmp/ab.txt 2>&1
tail -12 /tmp/ab.txt
grep "scatter_volume\|gather_volume\|total" /tmp/ab/case4-after-1.log
for s in oil-on-water; do
  bash .gpu/run .gpu/bin/mpm run --scene $s --frames 300 --backend cuda > /tmp/run-$s.txt 2>&1; tail -1 /tmp/run-$s.txt
done
bash .gpu/run .gpu/bin/mpm render --scene oil-on-water --frames 240 --out /tmp/oil --size 960x540 --colour material > /tmp/render.txt 2>&1; tail -3 /tmp/render.txt
mkdir -p /tmp/res/oil; for f in 00060 00120 00180 00240; do cp /tmp/oil/frame-$f.png /tmp/res/oil/; done
cp -r /tmp/g /tmp/ab /tmp/ab.txt /tmp/run-*.txt /tmp/render.txt /tmp/res/
tar cf $OUT/results.tar -C /tmp res
