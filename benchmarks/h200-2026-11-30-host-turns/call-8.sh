#!/usr/bin/env bash
# Session 24 call 8: main at 2e7feca (the final tree): gpu_materials, gpu_solids, gpu_bench side by
# side, then gpu_ranks alone.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm PATH=$PATH:/usr/local/cuda/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
for t in gpu_materials gpu_solids gpu_bench; do timeout 220 $P/$t > /tmp/$t.log 2>&1 & done
wait
timeout 150 $P/gpu_ranks > /tmp/gpu_ranks.log 2>&1
for t in gpu_materials gpu_solids gpu_bench gpu_ranks; do echo "$t: $(grep 'test result' /tmp/$t.log)"; grep -E "FAILED|panicked|not run|skipp" /tmp/$t.log | head -4; done | tee $OUT/tests.txt
cp /tmp/gpu_*.log $OUT/
