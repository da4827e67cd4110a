#!/usr/bin/env bash
# Session 28 call 11: the final build (35221c5): gpu_pbmpm and gpu_bench.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
L=/tmp/logs; rm -rf $L; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
for t in gpu_pbmpm gpu_bench; do
  timeout 150 $P/$t --nocapture > $L/$t.log 2>&1
  echo "$t: $(grep 'test result' $L/$t.log | tail -1)"; grep -E "^test .*(FAILED|ignored)|panicked" $L/$t.log | head -5
done
grep -E "RESULT pbmpm GPU pbmpm-1m|Martin.*1 iterations" $L/gpu_pbmpm.log | cut -c1-140
tar -czf $OUT/logs.tgz -C /tmp logs
