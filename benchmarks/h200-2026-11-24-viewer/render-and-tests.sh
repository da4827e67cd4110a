#!/usr/bin/env bash
set -u
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt 2>&1
bash .gpu/run true
B=.gpu/bin
common="--scene dam-break --frames 90 --backend cuda --no-images --draw surface"
for i in 1 2; do
  $B/mpm render $common --size 1920x1080 --timings $OUT/r1080-half-$i.json > $OUT/r1080-half-$i.log 2>&1
  $B/mpm render $common --size 1920x1080 --full-res-smoothing --timings $OUT/r1080-full-$i.json > $OUT/r1080-full-$i.log 2>&1
  $B/mpm-old render $common --size 1920x1080 --timings $OUT/r1080-old-$i.json > $OUT/r1080-old-$i.log 2>&1
done
$B/mpm render $common --size 960x540 > $OUT/r540-new.log 2>&1
$B/mpm-old render $common --size 960x540 > $OUT/r540-old.log 2>&1
for v in half full; do
  extra=""; [[ $v == full ]] && extra=--full-res-smoothing
  rm -rf /tmp/img-$v
  $B/mpm render --scene dam-break --frames 90 --backend cuda --draw surface --size 1920x1080 --out /tmp/img-$v $extra > $OUT/img-$v.log 2>&1
  cp /tmp/img-$v/frame-00090.png $OUT/img-$v-090.png; cp /tmp/img-$v/frame-00045.png $OUT/img-$v-045.png
done
bash .gpu/run .gpu/tests/all > $OUT/tests.log 2>&1; echo "tests exit $?" >> $OUT/tests.log
grep -E "^test result|FAILED|panicked|not run" $OUT/tests.log | sort | uniq -c > $OUT/tests-summary.txt
