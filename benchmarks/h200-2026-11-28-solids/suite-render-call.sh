#!/usr/bin/env bash
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
for f in $P/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv > $L/gpu.txt
timeout 60 $P/mpm run --scene jelly-drop --frames 180 --backend cuda > $L/jelly-drop-run.txt 2>&1
tail -3 $L/jelly-drop-run.txt
for s in sand-column snowball; do timeout 60 $P/mpm run --scene $s --frames 120 --backend cuda > $L/$s-run.txt 2>&1; tail -2 $L/$s-run.txt; done
mkdir -p $P/tests && for t in gpu_kernels gpu_materials gpu_lifecycle gpu_solids gpu_render; do mv $P/$t $P/tests/; done
( timeout 420 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 400 > $L/suite.txt 2>&1 ) &
( for s in jelly-drop:150 sand-column:90 snowball:45; do IFS=: read n f <<< "$s"; timeout 200 $P/mpm render --scene $n --frames $f --out /tmp/png-$n --size 1280x720 --colour material > $L/render-$n.log 2>&1; done ) &
wait
cp /tmp/png-jelly-drop/frame-00150.png $OUT/jelly-drop-150.png 2>/dev/null
cp /tmp/png-jelly-drop/frame-00060.png $OUT/jelly-drop-060.png 2>/dev/null
cp /tmp/png-sand-column/frame-00090.png $OUT/sand-column-090.png 2>/dev/null
cp /tmp/png-snowball/frame-00045.png $OUT/snowball-045.png 2>/dev/null
cat $L/suite.txt | tail -25
tail -2 $L/render-*.log
tar -czf $OUT/logs.tgz -C $OUT logs
