#!/usr/bin/env bash
# Session 20 call 4 (issue 47): the grid update's walk. w1: the next list entry loaded ahead; w2: the
# node blocks' marks walked in grid order instead of the list. Each against the embedded kernels.
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p22; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
M=$P/mpm; export NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
for w in 2 1; do
  STEPS=200 WARMUP=50 RUNS=2 OUT=/tmp/ab16-$w bash scripts/bench-ab.sh $M $M@$PWD/.gpu-exp/ptx-w$w "--particles 16777216 --grid 256" > $OUT/ab16-w$w.txt 2>&1
  grep '^|' $OUT/ab16-w$w.txt
  STEPS=800 WARMUP=100 RUNS=2 OUT=/tmp/ab-$w bash scripts/bench-ab.sh $M $M@$PWD/.gpu-exp/ptx-w$w "--scene dam-break" "--scene bench-65k" "--scene dam-break --scatter fixed-point" "--scene dam-break-1m" > $OUT/ab-w$w.txt 2>&1
  grep '^|' $OUT/ab-w$w.txt
done
