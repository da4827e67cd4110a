#!/usr/bin/env bash
# The viewer with its default real-time pacing: 857866a (mpm) against 0aa7704 (mpm-old).
set -u
R=/tmp/results; mkdir -p $R
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
one() { # binary tag args...
  local v=$1 tag=$2; shift 2
  bash scripts/view-on-gpu.sh --frames 400 --mpm .gpu/bin/$v --out $R/$v-$tag "$@" > $R/$v-$tag.script.log 2>&1
  echo "== $v $tag rc=$? $*"; grep "^viewer:" $R/$v-$tag/view.log | grep -v "frames drawn"; grep -i "failed" $R/$v-$tag/check.txt 2>/dev/null
}
for round in 1 2; do
  for v in mpm-old mpm; do one $v realtime-$round --fixed-frames 0; done
done
for v in mpm-old mpm; do one $v realtime-1080p --fixed-frames 0 --size 1920x1080; done
tar czf $OUT/viewer.tgz -C $R .
