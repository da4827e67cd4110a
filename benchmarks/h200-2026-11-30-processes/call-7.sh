#!/usr/bin/env bash
# Call 7: the final code's GPU tests that its change touches: the ranks on one GPU and on two (in
# one process and as two processes, the killed rank), NCCL alone and between two GPUs, the kernels
# and the benchmark. Writes tests.txt and the ranks' logs.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
timeout 330 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks,gpu_ranks_on_gpus,gpu_nccl,gpu_nccl_pair,gpu_kernels,gpu_bench --out /tmp/tests --timeout 300 > $OUT/tests.txt 2>&1
tail -10 $OUT/tests.txt; cp /tmp/tests/gpu_ranks*.log $OUT/ 2>/dev/null
grep -h "stopped" /tmp/tests/gpu_ranks_on_gpus.log
