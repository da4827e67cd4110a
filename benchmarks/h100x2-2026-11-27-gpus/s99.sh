#!/usr/bin/env bash
# compute-sanitizer memcheck of the two-GPU fixed-point tests with the API errors left out (s98's
# 272 reports included NCCL's own probes, error 209, and peer access already enabled, 704).
G=$PWD/.gpu
export NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
bash .gpu/run true
t2=$(ls $G/tests/gpu_ranks_on_gpus-*)
timeout 200 compute-sanitizer --tool memcheck --report-api-errors no --print-limit 50 $t2 two_gpus_gives --test-threads 1 > $OUT/memcheck.log 2>&1; echo "memcheck rc $?" > $OUT/summary.txt
grep -E "ERROR SUMMARY|test result|Invalid|^test " $OUT/memcheck.log | head -20 >> $OUT/summary.txt
