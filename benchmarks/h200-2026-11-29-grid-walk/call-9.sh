#!/usr/bin/env bash
# Session 20 call 9: the box vortex on the GPU (both scatters, 32 and 64 cells).
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p27; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
timeout 250 $P/gpu_materials a_box_vortex_decays_at_its_viscous_rate_in_both_scatters --nocapture 2>&1 | grep -E "RESULT|test result|panicked|failed"
