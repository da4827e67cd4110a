#!/usr/bin/env bash
# First run on two GPUs of one host: --gpus 2 (a rank per GPU, halos over NCCL, particles moved
# through peer access) against one GPU. The two-GPU tests, then weak and strong scaling benches
# (16.8M per GPU; a 33.5M column on 1 and 2), the dam break on 1 and 2, then the whole suite.
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
export MPM_BIN=$M NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
S=$OUT/summary.txt
bash .gpu/run true
{ nvidia-smi --query-gpu=name,driver_version --format=csv,noheader; nvidia-smi topo -m | head -4; $M devices; } > $S 2>&1
t2=$(ls $G/tests/gpu_ranks_on_gpus-*)
timeout 240 $t2 --nocapture --test-threads 1 > $OUT/two-gpus.log 2>&1; echo "two-GPU tests rc $?" >> $S
grep -E "^test |test result|ranks:|substeps|slabs|cut at" $OUT/two-gpus.log >> $S
mkdir -p /tmp/b; cd /tmp/b
bench() { # name args...
  local name=$1; shift
  local t0=$(date +%s)
  timeout 150 $M bench --backend cuda "$@" --json $name.json > $name.txt 2>&1; local rc=$?
  echo "== $name (rc $rc, $(( $(date +%s) - t0 )) s): $*" >> $S
  grep -E "total|halo|sort|g2p|grid_update|p2g|device|GPU" $name.txt | head -14 >> $S
}
bench dam1 --scene dam-break --steps 1000 --warmup 200
bench dam2 --scene dam-break --steps 1000 --warmup 200 --gpus 2
bench c16-1 --particles 16777216 --grid 256 --steps 200 --warmup 50
bench c16-2 --particles 16777216 --grid 256 --steps 200 --warmup 50 --gpus 2
bench c33-1 --particles 33554432 --grid 256 --steps 200 --warmup 50
bench c33-2 --particles 33554432 --grid 256 --steps 200 --warmup 50 --gpus 2
tar cf $OUT/bench.tar *.json *.txt
cd $G/..
timeout 300 bash .gpu/tests/all > $OUT/tests.log 2>&1; echo "suite rc $?" >> $S
grep -E "^=== |test result|not run" $OUT/tests.log >> $S
