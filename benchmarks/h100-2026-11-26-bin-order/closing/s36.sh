#!/usr/bin/env bash
# Final build against 06f9cc2 (mpm-head): PLY bytes, substeps, headless frames.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm H=$PWD/.gpu/bin/mpm-head
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s36
(cd /tmp; for sc in dam-break fountain; do
  timeout 90 $H run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export h-$sc > /dev/null 2>&1 || echo "head $sc failed"
  timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export n-$sc > /dev/null 2>&1 || echo "new $sc failed"
  MPM_BIN_ORDER=0 timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export o-$sc > /dev/null 2>&1 || echo "new off $sc failed"
  diff -rq h-$sc n-$sc > /dev/null && echo "$sc fixed point: $(ls n-$sc | wc -l) PLY files byte-identical, 06f9cc2 vs bin order" || echo "$sc DIFFER head vs bin order: $(diff -rq h-$sc n-$sc | wc -l)"
  diff -rq o-$sc n-$sc > /dev/null && echo "$sc fixed point: byte-identical, MPM_BIN_ORDER=0 vs 1" || echo "$sc DIFFER off vs on"
done
for v in head new; do b=$M; [ $v = head ] && b=$H; timeout 60 $b render --scene dam-break --scatter fixed-point --frames 30 --size 640x360 --out r-$v > /dev/null 2>&1 || echo "render $v failed"; done
diff -rq r-head r-new > /dev/null && echo "fixed-point surface frames: $(ls r-new | wc -l) files byte-identical 06f9cc2 vs new" || echo "fixed-point surface frames differ: $(diff -rq r-head r-new | wc -l)") | tee $OUT/s36/identity.txt
OUT=$OUT/s36/ab bash scripts/bench-ab.sh $H $M "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break --pipeline binned" 2>&1 | grep "^| " | tee $OUT/s36/bench.txt
STEPS=300 WARMUP=100 OUT=$OUT/s36/ab16 bash scripts/bench-ab.sh $H $M "--particles 16777216 --grid 256" 2>&1 | grep "^| \`" | tee -a $OUT/s36/bench.txt
rm -f $OUT/s36/ab/*.log $OUT/s36/ab16/*.log
for sc in "dam-break --size 960x540" "dam-break-1m --size 960x540" "dam-break --size 1920x1080"; do for v in head new head new; do b=$M; [ $v = head ] && b=$H
  echo "== $v render $sc"; timeout 60 $b render --scene $sc --frames 90 --no-images 2>&1 | grep -E "frames via"; done; done | tee $OUT/s36/render.txt
