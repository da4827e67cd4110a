#!/usr/bin/env bash
# Call 8: is the two processes' host cost theirs or the machine's? Two one-GPU benchmarks side by
# side (a process on each GPU, no ranks) against one alone; two processes of ranks with NCCL's cuMem
# off (NCCL_CUMEM_ENABLE=0); MPM_RANKS_HOST_TIMES=1 throughout. The dam break.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_RANKS_HOST_TIMES=1
nvidia-smi -L > $OUT/gpus.txt
R=/tmp/runs; mkdir -p $R
B="--scene dam-break --steps 400 --warmup 50"
{
echo "## one GPU, alone"; timeout 60 .gpu/bin/mpm bench $B > $R/alone.log 2>&1; grep -h "Wall" $R/alone.log
echo "## one GPU each, two processes side by side"
CUDA_VISIBLE_DEVICES=0 timeout 60 .gpu/bin/mpm bench $B > $R/side0.log 2>&1 &
CUDA_VISIBLE_DEVICES=1 timeout 60 .gpu/bin/mpm bench $B > $R/side1.log 2>&1 &
wait; grep -h "Wall" $R/side0.log $R/side1.log
echo "## ranks, one process"; timeout 60 .gpu/bin/mpm bench $B --gpus 2 > $R/one.log 2>&1; grep -h "Wall\|host" $R/one.log
for cumem in 1 0; do
  echo "## ranks, two processes, NCCL_CUMEM_ENABLE=$cumem"
  for rank in 1 0; do
    NCCL_CUMEM_ENABLE=$cumem RANK=$rank WORLD_SIZE=2 LOCAL_RANK=$rank LOCAL_WORLD_SIZE=2 MPM_RUN_ID=c$cumem timeout 60 .gpu/bin/mpm bench $B --processes > $R/p$cumem.$rank.log 2>&1 &
  done
  wait; grep -h "Wall\|host\|error" $R/p$cumem.0.log $R/p$cumem.1.log
done
} > $OUT/side-by-side.txt 2>&1
cat $OUT/side-by-side.txt
