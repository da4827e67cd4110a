#!/usr/bin/env bash
# Device call 7: one SVD for a return mapping and its stress: the solids' and the liquids' GPU
# suites, and the substep against the kernels before (MPM_PTX_DIR) with the same build.
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p7; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv | tee $L/gpu.txt
mkdir -p $P/tests && mv $P/gpu_solids $P/gpu_materials $P/gpu_kernels $P/tests/
timeout 300 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 280 > $L/suite.txt 2>&1
tail -5 $L/suite.txt
grep -h -A10 "worst error / tolerance" $L/tests/gpu_solids*.log | head -11
B=benches/scenes
STEPS=500 WARMUP=100 RUNS=2 OUT=$L/ab timeout 200 bash scripts/bench-ab.sh $P/mpm@$P/ptx-before $P/mpm "--scene dam-break" "--scene bench-655k" "--scene $B/bench-655k-sand.toml" "--scene $B/bench-655k-snow.toml" "--scene $B/bench-655k-jelly.toml" "--scene $B/bench-655k-elastoviscoplastic.toml" > $L/ab.txt 2>&1; tail -12 $L/ab.txt
tar -czf $OUT/logs.tgz -C $OUT logs
