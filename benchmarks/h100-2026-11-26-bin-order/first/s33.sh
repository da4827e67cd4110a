#!/usr/bin/env bash
# The whole suite on the working tree (particles in bin order).
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s33
timeout 330 bash .gpu/run .gpu/tests/all > $OUT/s33/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s33/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run|stored away" $OUT/s33/tests.log | head -20
