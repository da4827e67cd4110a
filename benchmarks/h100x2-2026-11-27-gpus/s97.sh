#!/usr/bin/env bash
# The CUDA ranks timed by events on rank 0's stream with no host wait between phases (mpm), against
# s96's build that waited for every rank at each phase's end (mpm-s96), in one call: the dam break,
# 16.8M and 33.5M columns on 1 and 2 GPUs; one GPU with particles in place (MPM_BIN_ORDER=0, as the
# ranks keep them); the largest column tried on 1 and 2 GPUs with the GPUs' memory sampled; then
# the two-GPU tests and the whole suite.
M=$PWD/.gpu/bin/mpm O=$PWD/.gpu/bin/mpm-s96 G=$PWD/.gpu
export MPM_BIN=$M NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
S=$OUT/summary.txt T0=$(date +%s)
bash .gpu/run true
mkdir -p /tmp/b; cd /tmp/b
bench() { # name binary args...
  local name=$1 bin=$2; shift 2
  local t0=$(date +%s)
  nvidia-smi --query-gpu=index,memory.used --format=csv,noheader,nounits -lms 500 > $name.mem 2>/dev/null & local smi=$!
  timeout 200 $bin bench --backend cuda "$@" --json $name.json > $name.txt 2>&1; local rc=$?
  kill $smi 2>/dev/null
  local mem=$(awk -F', ' '{if($2>m[$1])m[$1]=$2} END{for(i in m) printf "gpu%s %s MiB; ", i, m[i]}' $name.mem)
  echo "== $name (rc $rc, $(( $(date +%s) - t0 )) s, peak $mem): $*" >> $S
  grep -E "Wall clock|total|halo|migrate|rebin|one_pass|grid_update_b|rror" $name.txt | sed 's/(g2p + density + next whole scatter), //' | head -10 >> $S
}
for round in 1 2; do
  bench dam2-old-$round $O --scene dam-break --steps 1000 --warmup 200 --gpus 2
  bench dam2-new-$round $M --scene dam-break --steps 1000 --warmup 200 --gpus 2
done
bench dam1 $M --scene dam-break --steps 1000 --warmup 200
bench c16-1 $M --particles 16777216 --grid 256 --steps 600 --warmup 50
MPM_BIN_ORDER=0 bench c16-1-inplace $M --particles 16777216 --grid 256 --steps 600 --warmup 50
bench c16-2-old $O --particles 16777216 --grid 256 --steps 600 --warmup 50 --gpus 2
bench c16-2 $M --particles 16777216 --grid 256 --steps 600 --warmup 50 --gpus 2
bench c33-1 $M --particles 33554432 --grid 256 --steps 600 --warmup 50
bench c33-2-old $O --particles 33554432 --grid 256 --steps 600 --warmup 50 --gpus 2
bench c33-2 $M --particles 33554432 --grid 256 --steps 600 --warmup 50 --gpus 2
bench c268-1 $M --particles 268435456 --grid 512 --steps 40 --warmup 10
bench c268-2 $M --particles 268435456 --grid 512 --steps 40 --warmup 10 --gpus 2
tar cf $OUT/bench.tar *.json *.txt *.mem
cd $G/..
t2=$(ls $G/tests/gpu_ranks_on_gpus-*)
timeout 120 $t2 --nocapture --test-threads 1 > $OUT/two-gpus.log 2>&1; echo "two-GPU tests rc $?" >> $S
grep -E "test result" $OUT/two-gpus.log >> $S
timeout $(( 575 - ($(date +%s) - T0) )) bash .gpu/tests/all > $OUT/tests.log 2>&1; echo "suite rc $?" >> $S
grep -E "^=== |test result|not run" $OUT/tests.log >> $S
