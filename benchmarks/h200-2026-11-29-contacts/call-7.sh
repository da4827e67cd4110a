#!/usr/bin/env bash
# Device call 7 (issue 42): the floating logs' check in fixed point (deterministic; in float its
# 850 kg/m^3 log's tilt and 150 kg/m^3 log's draft sit near their bounds from run to run).
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p7; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
MPM_LOGS_SCATTER=fixed-point timeout 280 $P/gpu_bodies logs_float > $OUT/logs-fixed.txt 2>&1
grep -E "RESULT|test result|panicked" $OUT/logs-fixed.txt | cut -c1-220
