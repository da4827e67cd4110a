#!/usr/bin/env bash
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0
mkdir -p $OUT/e2
for t in gpu_bench gpu_kernels; do timeout 200 bash .gpu/run $(ls .gpu/tests/$t-*) --nocapture --test-threads 1 > $OUT/e2/$t.log 2>&1; echo "$t rc $?"; grep -E "^test result|FAILED|panicked" $OUT/e2/$t.log; done
grep -E "Fused: |Binned: |Report: " $OUT/e2/gpu_kernels.log | cut -c1-300 | head -3
