#!/usr/bin/env bash
# Device call 1 (issue 42, contacts): gpu_bodies (the pile of boxes against the CPU and run to run,
# the earlier checks), then ten cubes as static colliders against ten as bodies, floating apart and
# resting in piles (mpm bench, alternated twice).
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p1; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_bodies $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
timeout 240 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 230 > $L/suite.txt 2>&1
tail -4 $L/suite.txt; grep -h "cube\|RESULT dx = 0.0025\|panicked" $L/tests/*.log | head -20
B=benches/scenes
for r in 1 2; do for s in boxes-static boxes-bodies boxes-pile-static boxes-pile; do
  timeout 60 $P/mpm bench --scene $B/bench-$s.toml --steps 1000 --json $L/$s-$r.json > $L/$s-$r.txt 2>&1
  grep -E "^\| (total|grid update)" $L/$s-$r.txt | head -2 | sed "s/^/$s $r: /"
done; done
tar -czf $OUT/logs.tgz -C $L . && rm -rf $L
