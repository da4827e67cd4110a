#!/usr/bin/env bash
# Viewer: stepping beside the present (785f75e) against 0aa7704, windowed under Xvfb.
set -u
export NCCL_NVLS_ENABLE=0
R=/tmp/results; mkdir -p $R
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
one() { # name binary out-suffix args...
  local v=$1 tag=$2; shift 2
  bash scripts/view-on-gpu.sh --frames 300 --mpm .gpu/bin/$v --out $R/$v-$tag "$@" > $R/$v-$tag.script.log 2>&1
  echo "== $v $tag rc=$? $*"; grep "^viewer:" $R/$v-$tag/view.log | tail -3; tail -2 $R/$v-$tag/check.txt 2>/dev/null
}
for round in 1 2; do
  for v in mpm-old mpm; do one $v surface-$round; done
done
for v in mpm-old mpm; do one $v points -- --draw points; done
for v in mpm-old mpm; do one $v 1080p --size 1920x1080; done
for v in mpm-old mpm; do one $v fixed2 --fixed-frames 2; done
for v in mpm-old mpm; do one $v small --size 640x360; done
cp $R/mpm-surface-1/window.png $OUT/window-new.png 2>/dev/null
tar czf $OUT/viewer.tgz -C $R .
