#!/usr/bin/env bash
# Upper bounds, two PTX variants of be487f5's kernels, the same binary:
# - ptx-noret: the fixed-point tile's adds without their returns (tile_add_taken reads no result, so
#   no overflow is counted: timing only, not a correct build), for the fixed-point scenes;
# - ptx-gu16: grid_update_blocks held to 16 blocks per SM (64 registers, 144 bytes spilled on the
#   mirror path) against 72 registers, for the float scenes.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s77
fixed=("--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break-1m --scatter fixed-point" "--scene bench-655k")
(echo "== fixed tile without returns, ptx-noret"; OUT=$OUT/s77/noret RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-noret "${fixed[@]}" 2>&1 | grep "^| ") | tee $OUT/s77/ab.txt
float=("--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene fountain")
(echo "== grid_update_blocks at 16 blocks per SM, ptx-gu16"; OUT=$OUT/s77/gu16 RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-gu16 "${float[@]}" 2>&1 | grep "^| ") | tee -a $OUT/s77/ab.txt
