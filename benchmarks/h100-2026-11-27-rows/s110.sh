#!/usr/bin/env bash
# s110: one_pass_float_planes at 5 blocks per SM (96 registers, 48 bytes spilled; 94 before this
# session's gather by rows) against 4 (128, 0d24fd3), the large scenes the planes run.
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
export MPM_BIN=$M PATH=$PATH:/usr/local/cuda/bin
S=$OUT/summary.txt
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $S
bash .gpu/run true
(OUT=/tmp/ab RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-p5 "--scene dam-break" "--scene bench-655k" "--scene dam-break-1m" 2>&1 | grep "^| \`"
 OUT=/tmp/ab16 RUNS=1 STEPS=300 WARMUP=100 bash scripts/bench-ab.sh $M $M@$G/ptx-p5 "--particles 16777216 --grid 256" 2>&1 | grep "^| \`") | tee -a $S
