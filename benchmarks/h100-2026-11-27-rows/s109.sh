#!/usr/bin/env bash
# s109: the viewer in its window (Xvfb, NVIDIA GLX, CUDA-GL interop), the dam break's surface at
# 1280x720, 300 draws: 0d24fd3 twice, 3a153e5 (issue 18's start) once, interleaved, one frame a
# draw; then 0d24fd3 with the viewer's own real-time pacing.
set -u
export NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm O=$PWD/.gpu/old/mpm-3a153e5
R=/tmp/results; mkdir -p $R
bash .gpu/run true
S=$OUT/summary.txt
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $S
one() { local tag=$1 bin=$2; shift 2
  bash scripts/view-on-gpu.sh --frames 300 --mpm $bin --out $R/$tag "$@" > $R/$tag.script.log 2>&1
  echo "== $tag rc=$? $*"; grep "^viewer:" $R/$tag/view.log | grep -v "frames drawn"; grep -iE "failed|passed" $R/$tag/check.txt 2>/dev/null | head -3
  [ -f $R/$tag/view.log ] || tail -5 $R/$tag.script.log; }
(one new1 $M; one old1 $O; one new2 $M; one new-realtime $M --fixed-frames 0) | tee -a $S
cp $R/new1/window.png $OUT/window.png 2>/dev/null
