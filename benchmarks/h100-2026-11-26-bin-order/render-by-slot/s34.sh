#!/usr/bin/env bash
# Render attributes written at each particle's slot; one_pass reading places directly (ptx-direct) vs through order.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm H=$PWD/.gpu/bin/mpm-head
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s34
for t in gpu_kernels gpu_render; do timeout 200 bash .gpu/run .gpu/tests/$t-* > $OUT/s34/$t.log 2>&1; echo "$t rc $? $(grep -E '^test result' $OUT/s34/$t.log)"; grep -E "FAILED|panicked|stored away" $OUT/s34/$t.log; done
for sc in dam-break dam-break-1m; do for v in head new head new; do b=$M; [ $v = head ] && b=$H
  echo "== $v render $sc"; timeout 60 $b render --scene $sc --frames 90 --size 960x540 --no-images 2>&1 | grep -E "frames via|GPU ms per pass"; done; done | tee $OUT/s34/render.txt
(cd /tmp; for v in head new; do b=$M; [ $v = head ] && b=$H; timeout 60 $b render --scene dam-break --frames 30 --size 640x360 --out r-$v > /dev/null 2>&1 || echo "render $v failed"; done; diff -rq r-head r-new > /dev/null && echo "surface frames: $(ls r-new | wc -l) files byte-identical 06f9cc2 vs new" || echo "surface frames differ: $(diff -rq r-head r-new | wc -l)") | tee -a $OUT/s34/render.txt
OUT=$OUT/s34/ab bash scripts/bench-ab.sh $M $M@$PWD/.gpu/ptx-direct "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" 2>&1 | grep "^| " | tee $OUT/s34/direct.txt
rm -f $OUT/s34/ab/*.log
