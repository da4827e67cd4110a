#!/usr/bin/env bash
# The last read's mends: one helper for grid sums against a reference (tests), the tile's channels
# derived from the one_pass entry point chosen. The kernel tests, the bench test, a short bench of
# both scatter modes.
export MPM_BIN=$PWD/.gpu/bin/mpm PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s76
(timeout 200 .gpu/tests/gpu_kernels-* 2>&1 | grep -E "^test result|FAILED|panicked|next substep"
timeout 100 .gpu/tests/gpu_bench-* 2>&1 | grep -E "^test result|panicked"
for c in "--scene dam-break" "--scene dam-break --scatter fixed-point"; do echo "== $c"; timeout 60 $M bench $c --steps 500 --warmup 50 2>&1 | grep -E "one_pass \(|\*\*total"; done) | tee $OUT/s76/checks.txt
