#!/usr/bin/env bash
# Session 21 call 6 (issue 47): the wall/interior split (branch gridsplit, ebf3389) against its base
# 1dabe4d, one interleaved round each.
set -u
P=/tmp/p6; mkdir -p $P && tar -xJf .gpu-exp/split-pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
STEPS=800 WARMUP=100 RUNS=1 OUT=/tmp/ab6 timeout 130 bash scripts/bench-ab.sh $P/mpm-main $P/mpm \
  "--scene bench-65k" "--scene dam-break" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" > $OUT/ab.txt 2>&1
grep '^| `' $OUT/ab.txt
STEPS=200 WARMUP=50 RUNS=1 OUT=/tmp/ab6b timeout 100 bash scripts/bench-ab.sh $P/mpm-main $P/mpm "--particles 16777216 --grid 256" > $OUT/ab16.txt 2>&1
grep '^| `' $OUT/ab16.txt
