#!/usr/bin/env bash
# Device call 3 (issue 42, the final kernels and the dropped bodies merged): step_bodies' resolve
# works on a copy of each contact in registers (mpm; mpm@ptx-noresolvecopy is 6c49d58's step_bodies
# in the same build). The pile and floating rows, water alone against e675757, boats and the water
# wheel headless, gpu_bodies (with dropped_bodies_follow_the_cpu) and gpu_lifecycle.
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p3; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_* $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
B=benches/scenes
row() { echo "$1: $(grep -E '^\| mirror_walls' $2 | awk -F'|' '{print "grid", $3}') $(grep -E '^\| \*\*total' $2 | awk -F'|' '{print "total", $3}')"; }
for r in 1 2; do
  for s in boxes-static boxes-bodies boxes-pile-static boxes-pile; do
    timeout 60 $P/mpm bench --scene $B/bench-$s.toml --steps 1000 > $L/mpm-$s-$r.txt 2>&1; row "mpm $s $r" $L/mpm-$s-$r.txt
  done
  MPM_PTX_DIR=$P/ptx-noresolvecopy timeout 60 $P/mpm bench --scene $B/bench-boxes-pile.toml --steps 1000 > $L/noresolvecopy-boxes-pile-$r.txt 2>&1; row "noresolvecopy boxes-pile $r" $L/noresolvecopy-boxes-pile-$r.txt
  timeout 60 $P/mpm-old bench --scene $B/bench-boxes-pile.toml --steps 1000 > $L/mpm-old-boxes-pile-$r.txt 2>&1; row "mpm-old boxes-pile $r" $L/mpm-old-boxes-pile-$r.txt
done
STEPS=1000 WARMUP=100 RUNS=2 OUT=$L/ab timeout 120 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene dam-break" "--scene bench-655k" > $L/ab.txt 2>&1; tail -4 $L/ab.txt
for s in boats water-wheel; do timeout 60 $P/mpm run --scene $s --frames 300 > $L/$s-run.txt 2>&1; tail -1 $L/$s-run.txt | cut -c1-200; done
timeout 300 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 290 > $L/suite.txt 2>&1
tail -3 $L/suite.txt; grep -h "RESULT [0-9]* cells\|panicked\|dropped" $L/tests/*.log | head -8
tar -czf $OUT/logs.tgz -C $L . && rm -rf $L
