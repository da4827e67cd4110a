#!/usr/bin/env bash
# The viewer in a window (Xvfb, NVIDIA GLX, CUDA-GL interop), surface, 1280x720: d55b8d3 against 69d4162, one frame a draw; d55b8d3 with real-time pacing.
set -u
R=/tmp/results; mkdir -p $R
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
one() { local tag=$1 bin=$2; shift 2
  bash scripts/view-on-gpu.sh --frames 300 --mpm $bin --out $R/$tag "$@" > $R/$tag.script.log 2>&1
  echo "== $tag rc=$? $*"; grep "^viewer:" $R/$tag/view.log | grep -v "frames drawn"; grep -iE "failed|passed|note" $R/$tag/check.txt $R/$tag/view.log 2>/dev/null | head -4; }
export MPM_PTX_DIR=$PWD/.gpu/ptx-head; one head1 .gpu/old/mpm-head; unset MPM_PTX_DIR
one new1 .gpu/bin/mpm
export MPM_PTX_DIR=$PWD/.gpu/ptx-head; one head2 .gpu/old/mpm-head; unset MPM_PTX_DIR
one new2 .gpu/bin/mpm
one realtime .gpu/bin/mpm --fixed-frames 0
cp $R/new1/window.png $OUT/window.png
