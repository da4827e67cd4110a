#!/usr/bin/env bash
# The viewer in a window (Xvfb, NVIDIA GLX, CUDA-GL interop): d8498b1 (mpm, thickness by CUDA) against 1ba6235 (mpm-base);
# then fixed-point surface frames run to run.
set -u
R=/tmp/results; mkdir -p $R
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
one() { # binary tag args...
  local v=$1 tag=$2; shift 2
  bash scripts/view-on-gpu.sh --frames 300 --mpm .gpu/bin/$v --out $R/$v-$tag "$@" > $R/$v-$tag.script.log 2>&1
  echo "== $v $tag rc=$? $*"; grep "^viewer:" $R/$v-$tag/view.log | grep -v "frames drawn"; grep -iE "failed|note" $R/$v-$tag/check.txt $R/$v-$tag/view.log 2>/dev/null | head -5
}
for round in 1 2; do for v in mpm-base mpm; do one $v frame-$round; done; done
for v in mpm-base mpm; do one $v realtime --fixed-frames 0; done
cp $R/mpm-frame-1/window.png $OUT/window-new.png; cp $R/mpm-base-frame-1/window.png $OUT/window-base.png
M=$PWD/.gpu/bin/mpm
for k in 1 2; do timeout 120 $M render --scene dam-break --scatter fixed-point --frames 30 --size 960x540 --backend cuda --draw surface --out /tmp/fx$k > /dev/null 2>&1; done
diff -rq /tmp/fx1 /tmp/fx2 > /dev/null && echo "fixed point surface frames: $(ls /tmp/fx1 | wc -l) PNGs byte-identical run to run" || echo "fixed point frames DIFFER: $(diff -rq /tmp/fx1 /tmp/fx2 | wc -l)"
