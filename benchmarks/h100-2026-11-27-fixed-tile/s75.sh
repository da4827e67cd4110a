#!/usr/bin/env bash
# mpm bench's g2p row names one_pass's entry point: the bench test, and the labels at three sizes and
# in fixed point.
export MPM_BIN=$PWD/.gpu/bin/mpm PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s75
(timeout 120 .gpu/tests/gpu_bench-* 2>&1 | grep -E "^test result|panicked|g2p "
for c in "--scene bench-65k" "--scene dam-break" "--scene dam-break --scatter fixed-point" "--scene dam-break --pipeline binned"; do echo "== $c"; timeout 60 $M bench $c --steps 200 --warmup 20 2>&1 | grep -E "^\| (g2p|\*\*total)"; done) | tee $OUT/s75/labels.txt
