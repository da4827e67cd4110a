#!/usr/bin/env bash
# s114: the NCCL carrier holding its communicators alone (the library from Comm::nccl): the two-GPU
# tests, the ranks tests on one GPU of the pair, and a short two-GPU bench.
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
export MPM_BIN=$M NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
S=$OUT/summary.txt
nvidia-smi --query-gpu=name --format=csv,noheader | tee $S
bash .gpu/run true
for t in gpu_ranks_on_gpus gpu_nccl_pair gpu_ranks; do
  x=$(ls $G/tests/$t-*); timeout 200 $x > /tmp/$t.log 2>&1; echo "$t rc $? $(grep 'test result' /tmp/$t.log)" >> $S
  grep -E "panicked|FAILED" /tmp/$t.log | head -5 >> $S
done
timeout 100 $M bench --backend cuda --particles 16777216 --grid 256 --steps 200 --warmup 50 --gpus 2 > /tmp/b.txt 2>&1; echo "bench --gpus 2 rc $?" >> $S; grep -E "^###|\*\*total" /tmp/b.txt | cut -c1-160 >> $S
cat $S
