#!/usr/bin/env bash
# Blocks per SM for the tile scatters after tile_scatter (b9304f9): one_pass_fixed at 5 (96 registers)
# and 7 (72) against 6 (80); p2g_tiled at 5 (96) against 6 (80). The same binary, PTX variants.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s74
cases=("--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene bench-65k --scatter fixed-point")
for v in f5 f7; do echo "== one_pass_fixed, ptx-$v"; OUT=$OUT/s74/$v RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-$v "${cases[@]}" 2>&1 | grep "^| \`"; done | tee $OUT/s74/ab.txt
(echo "== p2g_tiled, ptx-t5"; OUT=$OUT/s74/t5 RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-t5 "--scene dam-break --pipeline binned --scatter fixed-point" "--scene bench-655k --pipeline binned --scatter fixed-point" 2>&1 | grep "^| \`") | tee -a $OUT/s74/ab.txt
