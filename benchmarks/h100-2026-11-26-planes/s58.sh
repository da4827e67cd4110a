#!/usr/bin/env bash
# The runs entry in 3/4/5 steps (ptx-runsteps) against 5 always (the packed build); fixed-point PLY
# and surface frames against HEAD 69d4162; headless frames against HEAD.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu H=$PWD/.gpu/old/mpm-head
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s58
OUT=$OUT/s58/runsteps RUNS=3 bash scripts/bench-ab.sh $M $M@$G/ptx-runsteps "--scene bench-65k" "--particles 131072" "--scene fountain" "--scene dam-break" 2>&1 | grep "^| " | tee $OUT/s58/runsteps.txt
(cd /tmp; for sc in dam-break fountain; do
  MPM_PTX_DIR=$G/ptx-head timeout 90 $H run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export h-$sc > /dev/null 2>&1 || echo "head $sc failed"
  timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export n-$sc > /dev/null 2>&1 || echo "new $sc failed"
  diff -rq h-$sc n-$sc > /dev/null && echo "$sc fixed point: $(ls n-$sc | wc -l) PLY files byte-identical, 69d4162 vs new" || echo "$sc DIFFER head vs new: $(diff -rq h-$sc n-$sc | wc -l)"
done
MPM_PTX_DIR=$G/ptx-head timeout 60 $H render --scene dam-break --scatter fixed-point --frames 30 --size 640x360 --out r-head > /dev/null 2>&1 || echo "render head failed"
timeout 60 $M render --scene dam-break --scatter fixed-point --frames 30 --size 640x360 --out r-new > /dev/null 2>&1 || echo "render new failed"
diff -rq r-head r-new > /dev/null && echo "fixed-point surface frames: $(ls r-new | wc -l) files byte-identical 69d4162 vs new" || echo "fixed-point surface frames differ: $(diff -rq r-head r-new | wc -l)") | tee $OUT/s58/identity.txt
for sc in "dam-break --size 960x540" "dam-break-1m --size 960x540" "dam-break --size 1920x1080"; do for v in head new head new; do
  echo "== $v render $sc"; if [ $v = head ]; then MPM_PTX_DIR=$G/ptx-head timeout 60 $H render --scene $sc --frames 90 --no-images 2>&1 | grep -E "frames via"; else timeout 60 $M render --scene $sc --frames 90 --no-images 2>&1 | grep -E "frames via"; fi; done; done | tee $OUT/s58/render.txt
