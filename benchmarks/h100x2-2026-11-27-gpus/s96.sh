#!/usr/bin/env bash
# s95 again after granting the peers access to each other's stream-ordered memory pools (the
# illegal addresses of s95): the two-GPU tests, the scaling benches, then the suite's executables
# that s95's timeout left unrun.
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
export MPM_BIN=$M NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
S=$OUT/summary.txt
bash .gpu/run true
t2=$(ls $G/tests/gpu_ranks_on_gpus-*)
timeout 240 $t2 --nocapture --test-threads 1 > $OUT/two-gpus.log 2>&1; echo "two-GPU tests rc $?" >> $S
grep -E "^test |test result|ranks:|substeps|slabs|cut at|error|panicked" $OUT/two-gpus.log | head -40 >> $S
mkdir -p /tmp/b; cd /tmp/b
bench() { # name args...
  local name=$1; shift
  local t0=$(date +%s)
  timeout 150 $M bench --backend cuda "$@" --json $name.json > $name.txt 2>&1; local rc=$?
  echo "== $name (rc $rc, $(( $(date +%s) - t0 )) s): $*" >> $S
  grep -E "total|halo|sort|g2p|grid_update|p2g|device|GPU|rror" $name.txt | head -14 >> $S
}
bench dam1 --scene dam-break --steps 1000 --warmup 200
bench dam2 --scene dam-break --steps 1000 --warmup 200 --gpus 2
bench c16-1 --particles 16777216 --grid 256 --steps 200 --warmup 50
bench c16-2 --particles 16777216 --grid 256 --steps 200 --warmup 50 --gpus 2
bench c33-1 --particles 33554432 --grid 256 --steps 200 --warmup 50
bench c33-2 --particles 33554432 --grid 256 --steps 200 --warmup 50 --gpus 2
tar cf $OUT/bench.tar *.json *.txt
cd $G/..
for t in gpu_render headless_render mesh_readers mpm scenarios scene_errors surface_export tap_preset transfers viewer_window walls; do
  for x in .gpu/tests/$t-*; do echo "=== $x"; timeout 120 $x 2>&1 | tail -n 30; done
done > $OUT/tests.log 2>&1
grep -E "^=== |test result|not run" $OUT/tests.log >> $S
