#!/usr/bin/env bash
# Session 22 call 7 (issue 42): gpu_bodies alone on the final tree (bodies refine their momentum
# units; the 150 kg/m^3 log asserted at 1.25 mm), Stokes aside (call 6: fixed point, 8 cells).
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
timeout 300 $P/gpu_bodies --skip a_sphere_settles_at_stokes_velocity --nocapture > /tmp/gpu_bodies.log 2>&1
echo "rc $?"; grep -E "^RESULT|test result|panicked|^test .*(ok|FAILED)" /tmp/gpu_bodies.log | tee $OUT/gpu_bodies.txt
