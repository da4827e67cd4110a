#!/usr/bin/env bash
# s106: bench-65k lost 1.8 % to the powers by squaring (s105, e1 and e3); is it powf's fallback code
# inlined beside them? ptx-e5: the fallback out of line (__noinline__); ptx-e6: no fallback at all
# (a timing probe, not a candidate). Against ptx-e3 and 767bb73's kernels (ptx-a).
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
export MPM_BIN=$M NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
S=$OUT/summary.txt
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $S
bash .gpu/run true
ab() { local label=$1 a=$2 b=$3 runs=$4; shift 4
  (echo "== $label"; OUT=/tmp/ab-$label RUNS=$runs bash scripts/bench-ab.sh $M@$G/$a $M@$G/$b "$@" 2>&1 | grep "^| \`") | tee -a $S; }
ab E3-E5 ptx-e3 ptx-e5 2 "--scene bench-65k" "--scene fountain" "--scene dam-break"
ab E3-E6 ptx-e3 ptx-e6 2 "--scene bench-65k"
ab A-E3 ptx-a ptx-e3 2 "--scene bench-65k"
ab A-E5 ptx-a ptx-e5 1 "--scene bench-65k" "--scene bench-655k" "--scene dam-break-1m"
cat $S
