#!/usr/bin/env bash
# s113: grid_update_blocks held to 16 and 20 blocks per SM (64 and 48 registers, spilling 144 and
# 538 bytes, mostly on the walls' mirror path) against 14 (72 registers, 59d2e1a's own kernels).
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
export MPM_BIN=$M PATH=$PATH:/usr/local/cuda/bin
S=$OUT/summary.txt
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $S
bash .gpu/run true
for v in gub16 gub20; do (echo "== head against $v"; OUT=/tmp/ab-$v RUNS=1 bash scripts/bench-ab.sh $M $M@$G/ptx-$v "--scene dam-break" "--scene bench-655k" "--scene dam-break-1m" "--scene bench-65k" "--scene dam-break --scatter fixed-point" 2>&1 | grep "^| \`") | tee -a $S; done
