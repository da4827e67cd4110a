#!/usr/bin/env bash
# The two-GPU host: topology, mpm devices, NCCL across the pair (gpu_nccl_pair), and the one-GPU
# NCCL and ranks suites there.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0
nvidia-smi -L; nvidia-smi topo -m
echo "== mpm devices"; timeout 60 .gpu/bin/mpm devices
for t in gpu_nccl_pair gpu_nccl gpu_ranks; do
  echo "== $t"; timeout 240 bash .gpu/run .gpu/tests/$t 2>&1 | grep -vE "^$" | tail -25
done
