#!/usr/bin/env bash
# Device call 3 (issue 45): the exports as they now land (PLY on writer threads of its own, the
# queues sized by a memory budget, a staging copy's wait counted as a wait): the dam break's 120
# frames headless, each export every frame and every 6th; gpu_lifecycle (with the viewer's
# hand-over between overlapped frames; the X11 tree for a real window does not fit beside the
# checkout in a device call); then Stokes at 10 cells in the float scatter (issue 42: does fixed point's
# impulse rounding explain the -40 %?).
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p3; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_* $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=index,name,driver_version --format=csv,noheader
W=/tmp/w3; mkdir -p $W
cost() { # name frames binary args...
  local name=$1 frames=$2 bin=$3; shift 3
  rm -rf $W/*; ( cd $W && /usr/bin/time -f "peak-rss %M KiB" timeout 200 $bin run --scene dam-break --frames $frames --overwrite "$@" ) > $L/$name.txt 2>&1
  echo "$name: $(grep -E '^time:' $L/$name.txt | cut -c7-75) | $(grep -E '^export:' $L/$name.txt | cut -c8-60),$(grep -E '^export:' $L/$name.txt | grep -o 'which waited.*') | $(grep 'peak-rss' $L/$name.txt)"
}
$P/mpm run --scene dam-break --frames 1 > /dev/null 2>&1  # the driver's kernel cache
for r in 1 2; do
  cost none-$r 120 $P/mpm
  cost ply-$r 120 $P/mpm --export ply
  cost usd-$r 120 $P/mpm --export-usd stage.usda
done
cost ply6 120 $P/mpm --export ply --every 6
cost usd6 120 $P/mpm --export-usd stage.usda --every 6
cost surface6 120 $P/mpm --export-surface surf --surface-format ply --every 6
cost none-60 60 $P/mpm
cost volume6-60 60 $P/mpm --export-volume vol --every 6
grep -h "^export thread\|^exported\|^surface:\|^volume:\|^usd:" $L/ply-1.txt $L/usd-1.txt $L/surface6.txt $L/volume6-60.txt | cut -c1-240
timeout 200 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --only gpu_lifecycle --out $L/tests --timeout 190 > $L/suite.txt 2>&1
tail -2 $L/suite.txt
MPM_STOKES_SCATTER=float MPM_STOKES_CELLS=10 MPM_STOKES_FILLS=2 timeout 200 $P/tests/gpu_bodies a_sphere_settles_at_stokes_velocity --nocapture > $L/stokes.log 2>&1; echo "stokes rc $?" >> $L/stokes.log
grep -h "cells, t =\|RESULT\|stokes rc\|finished in" $L/stokes.log
tar -czf $OUT/logs.tgz -C $L . && rm -rf $L
