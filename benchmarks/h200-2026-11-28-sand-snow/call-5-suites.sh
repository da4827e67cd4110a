#!/usr/bin/env bash
# Device call 5: gpu_solids (new: snow and sand follow the CPU, the angle of repose, the snowball
# preset breaking) and gpu_kernels (every preset spawns as the host does), and a picture of the
# snowball preset.
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p5; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
for f in $P/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
mkdir -p $P/tests && mv $P/gpu_solids $P/gpu_kernels $P/tests/
( timeout 560 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 540 > $L/suite.txt 2>&1 ) &
mkdir -p /tmp/snow
( timeout 400 $P/mpm render --scene snowball --frames 24 --size 1280x720 --colour material --out /tmp/snow > $L/render.txt 2>&1; echo "rc $?" >> $L/render.txt ) &
wait
ls /tmp/snow | head -30 >> $L/render.txt
mkdir -p $OUT/png; for f in 6 9 12 18 24; do cp /tmp/snow/*$(printf %06d $f)*.png $OUT/png/ 2>/dev/null; done
tail -8 $L/suite.txt
tar -czf $OUT/logs.tgz -C $OUT logs
