#!/usr/bin/env bash
# Device call 2 (issue 45): the dam break's 120 frames headless by this tree (`mpm`: the closing
# lines split the stepping thread's own cost from its waits, the reorder on rayon's pool) and by
# 5db3a1c (`mpm-old`), each export every frame and every 6th; then Stokes at 10 cells over three
# tube-filling times (issue 42).
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p2; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_* $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=index,name,driver_version --format=csv,noheader
W=/tmp/w2; mkdir -p $W; df -h /tmp | tail -1
cost() { # name binary args...
  local name=$1 bin=$2; shift 2
  rm -rf $W/*; ( cd $W && /usr/bin/time -f "peak-rss %M KiB" timeout 200 $bin run --scene dam-break --frames 120 --overwrite "$@" ) > $L/$name.txt 2>&1
  echo "$name: $(grep -E '^time:' $L/$name.txt | cut -c8-70) | $(grep -E '^export:' $L/$name.txt | cut -c8-200) | $(grep 'peak-rss' $L/$name.txt)"
}
$P/mpm run --scene dam-break --frames 1 > /dev/null 2>&1  # the driver's kernel cache
for r in 1 2; do
  cost mpm-none-$r $P/mpm
  cost mpm-ply-$r $P/mpm --export ply
  cost mpm-ply6-$r $P/mpm --export ply --every 6
  cost mpm-usd-$r $P/mpm --export-usd stage.usda
  cost mpm-usd6-$r $P/mpm --export-usd stage.usda --every 6
done
for b in mpm-old mpm; do
  cost $b-ply6 $P/$b --export ply --every 6
  cost $b-usd6 $P/$b --export-usd stage.usda --every 6
  cost $b-surface6 $P/$b --export-surface surf --surface-format ply --every 6
  cost $b-volume6 $P/$b --export-volume vol --every 6
done
cost mpm-volume6-velocity $P/mpm --export-volume vol --every 6 --volume-velocity
cost mpm-all6 $P/mpm --export ply --export-usd stage.usda --export-surface surf --export-volume vol --every 6
grep -h "^export thread\|^exported\|^surface:\|^volume:\|^usd:" $L/mpm-*-1.txt $L/mpm-*6.txt $L/mpm-all6.txt | cut -c1-220
MPM_STOKES_CELLS=10 MPM_STOKES_FILLS=3 timeout 280 $P/tests/gpu_bodies a_sphere_settles_at_stokes_velocity --nocapture > $L/stokes.log 2>&1; echo "stokes rc $?" >> $L/stokes.log
grep -h "cells, t =\|RESULT\|stokes rc\|finished in" $L/stokes.log
tar -czf $OUT/logs.tgz -C $L . && rm -rf $L
