#!/usr/bin/env bash
# s105: choosing among s104's refinements, one binary (s104's), kernels through MPM_PTX_DIR:
#   ptx-e1: the gather by rows in every one_pass entry point, one_pass_fixed at 5 blocks per SM
#           (96 registers), the Tait powers by squaring in a loop;
#   ptx-e3: e1 with the squaring unrolled over the exponent's 5 bits;
#   ptx-e4: e1 with one_pass_float (the small scenes' entry point) at 4 blocks per SM (128 registers,
#           no spills: a 65k scene fills 4 blocks per SM anyway).
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
export MPM_BIN=$M NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
S=$OUT/summary.txt
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $S
bash .gpu/run true
ab() { local label=$1 a=$2 b=$3 runs=$4; shift 4
  (echo "== $label"; OUT=/tmp/ab-$label RUNS=$runs bash scripts/bench-ab.sh $M@$G/$a $M@$G/$b "$@" 2>&1 | grep "^| \`") | tee -a $S; }
ab A-E1 ptx-a ptx-e1 1 "--scene bench-65k" "--scene fountain" "--scene dam-break" "--scene bench-655k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point"
ab E1-E3 ptx-e1 ptx-e3 1 "--scene bench-65k" "--scene dam-break" "--scene bench-655k"
ab E1-E4 ptx-e1 ptx-e4 2 "--scene bench-65k" "--scene fountain"
ab A-E4 ptx-a ptx-e4 1 "--scene bench-65k" "--scene fountain"
cat $S
