#!/usr/bin/env bash
# Call 3: the single-GPU suite, and the several-liquids check twice more.
set -u
rm -rf .gpu; mkdir -p .gpu && tar xJf .gpu-pack9/pack.tar.xz -C .gpu
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/device.txt
timeout 480 bash .gpu/run bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --out /tmp/g --timeout 300 2>&1 | tail -15
for i in 1 2; do
  timeout 60 bash .gpu/run .gpu/tests/gpu_materials-* every_pipeline_follows_the_cpu_with_several_liquids > /tmp/g/flake-$i.txt 2>&1
  grep "test result\|FAILED\|panicked" /tmp/g/flake-$i.txt | head -3
done
tar cf $OUT/logs.tar -C /tmp g
