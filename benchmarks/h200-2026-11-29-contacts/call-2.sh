#!/usr/bin/env bash
# Device call 2 (issue 42): the merged tree (contacts, checkpoints with bodies, --export-bodies):
# gpu_bodies (Stokes' settling at 6 and 8 cells, the pile), gpu_lifecycle (a resumed run with a
# body), gpu_kernels; water-wheel and boats headless (their cost) and water-wheel drawn for the
# docs; --export-bodies on the GPU; water alone before (5602c5d) and after.
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p2; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_* $P/tests/
for f in $P/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
timeout 330 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 320 > $L/suite.txt 2>&1
tail -5 $L/suite.txt; grep -h "RESULT [0-9]* cells\|cube [0-9]:\|panicked" $L/tests/*.log | head -12
timeout 100 $P/mpm run --scene water-wheel --frames 300 --stats $L/wheel.jsonl > $L/wheel-run.txt 2>&1; tail -2 $L/wheel-run.txt | cut -c1-400
timeout 100 $P/mpm run --scene boats --frames 300 > $L/boats-run.txt 2>&1; tail -1 $L/boats-run.txt | cut -c1-300
mkdir -p /tmp/eb; timeout 60 $P/mpm run --scene ball-drop --frames 12 --export-bodies /tmp/eb --export-every 4 > $L/export-bodies.txt 2>&1; tail -1 $L/export-bodies.txt; ls /tmp/eb; cp /tmp/eb/bodies.csv $L/
mkdir -p /tmp/wheel; timeout 120 $P/mpm render --scene water-wheel --frames 150 --size 1280x720 --out /tmp/wheel > $L/wheel-render.txt 2>&1; tail -2 $L/wheel-render.txt
mkdir -p $OUT/png; for f in 60 150; do cp /tmp/wheel/frame-$(printf %05d $f).png $OUT/png/wheel-$f.png; done
STEPS=1000 WARMUP=100 RUNS=2 OUT=$L/ab timeout 120 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene dam-break" "--scene bench-655k" > $L/ab.txt 2>&1; tail -4 $L/ab.txt
tar -czf $OUT/logs.tgz -C $L . && rm -rf $L
