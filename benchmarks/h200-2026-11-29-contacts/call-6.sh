#!/usr/bin/env bash
# Device call 6 (issue 42): ten floating bodies cost 5.9 % of a substep (call 5), 10 us of it in the
# grid update beside step_bodies. Tried: the lanes of a warp giving to one body add their fixed-point
# units first and one lane adds the warp's share (mpm, against 59e4460's mpm-old): the bench rows,
# water alone, gpu_bodies (the GPU against the CPU, fixed point run to run).
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p6; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_* $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
B=benches/scenes
for r in 1 2; do for b in mpm-old mpm; do for s in boxes-static boxes-bodies; do
  timeout 60 $P/$b bench --scene $B/bench-$s.toml --steps 1000 > $L/$b-$s-$r.txt 2>&1
  echo "$b $s $r: $(grep -E '^\| mirror_walls' $L/$b-$s-$r.txt | awk -F'|' '{print "grid", $3}') $(grep -E '^\| \*\*total' $L/$b-$s-$r.txt | awk -F'|' '{print "total", $3}')"
done; done; done
STEPS=1000 WARMUP=100 RUNS=2 OUT=$L/ab timeout 120 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene dam-break" "--scene bench-655k" > $L/ab.txt 2>&1; tail -4 $L/ab.txt
timeout 200 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 190 > $L/suite.txt 2>&1
tail -3 $L/suite.txt; grep -h "RESULT [0-9]* cells\|panicked" $L/tests/*.log | head -6
tar -czf $OUT/logs.tgz -C $L . && rm -rf $L
