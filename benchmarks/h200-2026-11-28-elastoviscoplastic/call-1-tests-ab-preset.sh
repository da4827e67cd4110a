#!/usr/bin/env bash
# Device call 1 (session 13): the elastoviscoplastic mud's GPU tests, water-only speed against the
# build before, the bench rows, the mud preset's run and picture.
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
for f in $P/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version,clocks.max.sm --format=csv | tee $L/gpu.txt
mkdir -p $P/tests && for t in gpu_kernels gpu_materials gpu_solids; do mv $P/$t $P/tests/; done
timeout 330 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 320 > $L/suite.txt 2>&1
tail -15 $L/suite.txt
STEPS=1000 WARMUP=100 RUNS=2 OUT=$L/ab timeout 170 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene dam-break" "--scene bench-655k" "--scene benches/scenes/bench-655k-herschel-bulkley.toml" > $L/ab.txt 2>&1; tail -14 $L/ab.txt
timeout 40 $P/mpm bench --scene benches/scenes/bench-655k-elastoviscoplastic.toml --scene benches/scenes/bench-655k-herschel-bulkley.toml --steps 1000 > $L/bench-evp.txt 2>&1; tail -12 $L/bench-evp.txt
timeout 60 $P/mpm run --scene mud-dam-break --frames 240 --backend cuda --export /tmp/o/mud --every 30 > $L/mud-run.txt 2>&1; tail -4 $L/mud-run.txt
timeout 30 python3 $P/mud.py $P /tmp/o/mud > $L/mud-analyse.txt 2>&1; cat $L/mud-analyse.txt
timeout 60 $P/mpm render --scene mud-dam-break --frames 240 --out /tmp/png-mud --size 1280x720 --colour material > $L/render-mud.log 2>&1; tail -2 $L/render-mud.log
cp /tmp/png-mud/frame-00240.png $OUT/mud-240.png 2>/dev/null; cp /tmp/png-mud/frame-00045.png $OUT/mud-045.png 2>/dev/null
tar -czf $OUT/logs.tgz -C $OUT logs
