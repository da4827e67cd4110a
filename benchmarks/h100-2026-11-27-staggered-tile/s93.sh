#!/usr/bin/env bash
# Timing only, physics wrong: bounds on what the float pass's gather and runs cost, 200 substeps
# from the start (the flow barely moves in them): one_pass_float_planes gathering from the first 256
# grid nodes (ptx-ng: every gather an L1 hit), or without the runs' sums (ptx-ns: no shuffles;
# heads add their own values), against e52e2e0 (the binary's kernels: 7f195ad's instructions).
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s93
cases=("--scene dam-break" "--scene bench-655k" "--scene dam-break-1m")
(for v in ng ns; do echo "== head against ptx-$v"; OUT=$OUT/s93/$v RUNS=2 STEPS=200 WARMUP=20 bash scripts/bench-ab.sh $M $M@$G/ptx-$v "${cases[@]}" 2>&1 | grep "^| \`"; done) | tee $OUT/s93/ab.txt
