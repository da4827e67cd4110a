#!/usr/bin/env bash
# The viewer in a window at aaa076d (Xvfb, NVIDIA GLX, CUDA-GL interop): surface, one frame a draw and real-time pacing; points.
set -u
R=/tmp/results; mkdir -p $R
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
one() { local tag=$1; shift
  bash scripts/view-on-gpu.sh --frames 300 --mpm .gpu/bin/mpm --out $R/$tag "$@" > $R/$tag.script.log 2>&1
  echo "== $tag rc=$? $*"; grep "^viewer:" $R/$tag/view.log | grep -v "frames drawn"; grep -iE "failed|passed|note" $R/$tag/check.txt $R/$tag/view.log 2>/dev/null | head -4; }
one frame; one realtime --fixed-frames 0; one points -- --draw points
cp $R/frame/window.png $OUT/window.png
