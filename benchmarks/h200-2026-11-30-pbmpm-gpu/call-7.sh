#!/usr/bin/env bash
# Session 25 call 7: the final build's GPU tests (gpu_pbmpm, and the suites the solver's changes reach).
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
timeout 400 $P/gpu_pbmpm --nocapture > $L/gpu_pbmpm.log 2>&1 &
for t in gpu_kernels gpu_lifecycle gpu_materials gpu_solids gpu_physics gpu_render; do timeout 420 $P/$t > $L/$t.log 2>&1 & done
wait
for t in gpu_pbmpm gpu_kernels gpu_lifecycle gpu_materials gpu_solids gpu_physics gpu_render; do echo "$t: $(grep 'test result' $L/$t.log)"; grep -E "FAILED|panicked|not run" $L/$t.log | head -4; done
grep -E "RESULT" $L/gpu_pbmpm.log | grep -v "t = " | cut -c1-200
tar -czf $OUT/logs.tgz -C /tmp logs
