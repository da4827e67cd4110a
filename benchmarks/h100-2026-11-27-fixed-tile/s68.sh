#!/usr/bin/env bash
# The viewer in a window (Xvfb, NVIDIA GLX, CUDA-GL interop), surface, 1280x720, one frame a draw:
# mpm-a (8a2d656 with the handover timed, a thread a draw) against mpm-b (the same with one stepping
# thread for the viewer's life), interleaved; then each with real-time pacing.
set -u
R=/tmp/results; mkdir -p $R $OUT/s68
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
one() { local tag=$1 bin=$2; shift 2
  bash scripts/view-on-gpu.sh --frames 300 --mpm $bin --out $R/$tag "$@" > $R/$tag.script.log 2>&1
  echo "== $tag rc=$? $*"; grep "^viewer:" $R/$tag/view.log | grep -v "frames drawn"; grep -iE "failed|passed|note" $R/$tag/check.txt 2>/dev/null | head -4; }
(for r in 1 2 3; do one a$r .gpu/viewer/mpm-a; one b$r .gpu/viewer/mpm-b; done
one a-realtime .gpu/viewer/mpm-a --fixed-frames 0; one b-realtime .gpu/viewer/mpm-b --fixed-frames 0) | tee $OUT/s68/viewer.txt
cp $R/b1/window.png $OUT/s68/window-b1.png
