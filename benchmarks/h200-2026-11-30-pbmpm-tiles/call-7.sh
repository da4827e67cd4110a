#!/usr/bin/env bash
# Session 27 call 7: pbmpm_diffuse rounded as the CPU rounds: gpu_pbmpm.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
timeout 150 $P/gpu_pbmpm --nocapture > $L/gpu_pbmpm.log 2>&1
echo "gpu_pbmpm: $(grep 'test result' $L/gpu_pbmpm.log)"; grep -E "^test .*(FAILED|ignored)|panicked" $L/gpu_pbmpm.log | head
grep RESULT $L/gpu_pbmpm.log | grep -E "frame 30:|honey" | cut -c1-200
tar -czf $OUT/logs.tgz -C /tmp logs
