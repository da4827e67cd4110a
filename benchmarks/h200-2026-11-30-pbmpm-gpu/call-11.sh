#!/usr/bin/env bash
# Session 25 call 11: every liquid gets the viscosity sweep's buffers (a live viscosity on an inviscid
# scene); gpu_pbmpm whole.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
timeout 200 $P/gpu_pbmpm --nocapture > $L/gpu_pbmpm.log 2>&1
grep -E "^test |test result" $L/gpu_pbmpm.log
timeout 60 $P/mpm bench --scene pbmpm-dam-break --steps 100 --warmup 10 > $L/bench-pbmpm-dam-break.txt 2>&1; grep -o 'Wall clock: [0-9.]* ms' $L/bench-pbmpm-dam-break.txt
tar -czf $OUT/logs.tgz -C /tmp logs
