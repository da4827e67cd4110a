#!/usr/bin/env bash
# Device call 1 (issue 45: the export off the stepping thread). On GPU 0: the dam break's 120
# frames headless with each export and without, by 5db3a1c (`mpm-old`: the particles read back
# synchronously on the stepping thread) and by this tree (`mpm`: the export thread and the
# asynchronous snapshot), each twice; the fixed-point coarse dam break's PLY frames of both
# binaries compared byte for byte; gpu_lifecycle (the snapshot test); then Stokes' settling at 8
# cells over six tube-filling times (issue 42).
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p1; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_* $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=index,name,driver_version --format=csv,noheader
W=/tmp/w1; mkdir -p $W
cost() { # name binary args...
  local name=$1 bin=$2; shift 2
  rm -rf $W/*; ( cd $W && /usr/bin/time -f "peak-rss %M KiB" timeout 200 $bin run --scene dam-break --frames 120 --overwrite "$@" ) > $L/$name.txt 2>&1
  echo "$name: $(grep -E '^time:' $L/$name.txt | cut -c1-160) | $(grep -E '^export:' $L/$name.txt | cut -c1-130) | $(grep 'peak-rss' $L/$name.txt)"
}
for r in 1 2; do
  for b in mpm-old mpm; do
    cost $b-none-$r $P/$b
    cost $b-ply-$r $P/$b --export ply
    cost $b-usd-$r $P/$b --export-usd stage.usda
    [ $r = 1 ] && cost $b-surface6-$r $P/$b --export-surface surf --surface-format ply --export-every 6
    [ $r = 1 ] && cost $b-volume6-$r $P/$b --export-volume vol --export-every 6
  done
done
cost mpm-all $P/mpm --export ply --export-usd stage.usda --export-surface surf --export-volume vol --export-every 6
for b in mpm-old mpm; do
  ( cd $W && rm -rf $b && timeout 60 $P/$b run --scene dam-break-coarse --frames 10 --backend cuda --scatter fixed-point --export $b > /dev/null 2>&1 )
done
echo "PLY frames old vs new: $(cd $W && ls mpm | wc -l) files, $(diff -rq $W/mpm-old $W/mpm > /dev/null && echo identical || echo DIFFER)"
timeout 300 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --only gpu_lifecycle --out $L/tests --timeout 290 > $L/suite.txt 2>&1
tail -3 $L/suite.txt
MPM_STOKES_CELLS=8 MPM_STOKES_FILLS=6 timeout 240 $P/tests/gpu_bodies a_sphere_settles_at_stokes_velocity --nocapture > $L/stokes.log 2>&1; echo "stokes rc $?" >> $L/stokes.log
grep -h "RESULT\|stokes rc\|panicked" $L/stokes.log
tar -czf $OUT/logs.tgz -C $L . && rm -rf $L
