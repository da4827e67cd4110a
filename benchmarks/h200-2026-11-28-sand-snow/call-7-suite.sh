#!/usr/bin/env bash
# Device call 7: gpu_solids, the whole suite with the sand columns at 2.5 and 1.25 mm added.
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p7; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
mkdir -p $P/tests && mv $P/gpu_solids $P/tests/
timeout 560 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 540 > $L/suite.txt 2>&1
tail -4 $L/suite.txt
grep -E "Lube et al\. [0-9]|bank stands|pieces of" $L/tests/gpu_solids.log
