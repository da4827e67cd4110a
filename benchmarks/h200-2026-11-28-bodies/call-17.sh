#!/usr/bin/env bash
# Device call 17 (issue 42): ten cubes as static colliders against ten as rigid bodies (mpm bench,
# alternated twice), then the suites that run colliders and bodies on the final build.
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p17; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
B=benches/scenes
for r in 1 2; do for s in static bodies; do
  timeout 60 $P/mpm bench --scene $B/bench-boxes-$s.toml --steps 1000 --json $L/boxes-$s-$r.json > $L/boxes-$s-$r.txt 2>&1
  grep -E "^\| total" $L/boxes-$s-$r.txt | head -1 | sed "s/^/$s $r: /"
done; done
mkdir -p $P/tests && mv $P/gpu_bodies $P/gpu_kernels $P/gpu_lifecycle $P/tests/
timeout 360 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 350 > $L/suite.txt 2>&1
tail -5 $L/suite.txt
tar -czf $OUT/logs.tgz -C $L . && rm -rf $L
