#!/usr/bin/env bash
# The viewer in a window (Xvfb, NVIDIA GLX, CUDA-GL interop): baa8369 (mpm, particles in bin order) against 06f9cc2 (mpm-head).
set -u
R=/tmp/results; mkdir -p $R
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
one() { # binary tag args...
  local v=$1 tag=$2; shift 2
  bash scripts/view-on-gpu.sh --frames 300 --mpm .gpu/bin/$v --out $R/$v-$tag "$@" > $R/$v-$tag.script.log 2>&1
  echo "== $v $tag rc=$? $*"; grep "^viewer:" $R/$v-$tag/view.log | grep -v "frames drawn"; grep -i "failed" $R/$v-$tag/check.txt 2>/dev/null
}
for round in 1 2; do for v in mpm-head mpm; do one $v frame-$round; done; done
for v in mpm-head mpm; do one $v realtime --fixed-frames 0; done
for v in mpm-head mpm; do one $v points -- --draw points; done
rm -f $R/*/screen.png
tar czf $OUT/viewer.tgz -C $R .
