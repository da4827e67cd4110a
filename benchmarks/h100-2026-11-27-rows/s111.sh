#!/usr/bin/env bash
# s111: two GPUs with 2206ffd (the gather by rows, the impulse by planes, the powers by squaring,
# count_layers over a grid-stride launch): the two-GPU tests, then the scaling runs of BENCHMARKS.md
# 0x again (one call; 0x's figures are s101's).
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
export MPM_BIN=$M NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
S=$OUT/summary.txt
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $S
bash .gpu/run true
for t in gpu_ranks_on_gpus gpu_nccl_pair; do
  x=$(ls $G/tests/$t-*); timeout 200 $x > /tmp/$t.log 2>&1; echo "$t rc $? $(grep 'test result' /tmp/$t.log)" >> $S
  grep -E "panicked|FAILED|not run" /tmp/$t.log | head -5 >> $S
done
cp /tmp/gpu_ranks_on_gpus.log $OUT/tests.log
mkdir -p /tmp/b; cd /tmp/b
bench() { local name=$1; shift
  timeout 120 $M bench --backend cuda "$@" --json $name.json > $name.txt 2>&1; echo "== $name rc $?: $*" >> $S
  grep -E "Wall clock|\*\*total|halo|migrate" $name.txt | cut -c1-170 | head -6 >> $S
}
bench c16-1 --particles 16777216 --grid 256 --steps 600 --warmup 50
bench c33-1 --particles 33554432 --grid 256 --steps 600 --warmup 50
bench c16-2 --particles 16777216 --grid 256 --steps 600 --warmup 50 --gpus 2
bench c33-2 --particles 33554432 --grid 256 --steps 600 --warmup 50 --gpus 2
bench dam-2 --scene dam-break --steps 1000 --warmup 200 --gpus 2
bench dam-1 --scene dam-break --steps 1000 --warmup 200
tar cf $OUT/bench.tar *.json *.txt
cat $S
