#!/usr/bin/env bash
# mpm render: 4b9c480 (mpm, the next frame stepped beside the drawing) against 0aa7704 (mpm-old).
set -u
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
B=.gpu/bin
r() { # binary label args...
  local v=$1 l=$2; shift 2
  echo "== $v $l"; $B/$v render "$@" 2>&1 | grep -E "frames via|GPU ms per pass|error|Error"
}
for round in 1 2; do
  for v in mpm-old mpm; do r $v "dam break 960x540" --scene dam-break --frames 90 --size 960x540 --no-images; done
done
for v in mpm-old mpm; do r $v "dam-break-1m 960x540" --scene dam-break-1m --frames 90 --size 960x540 --no-images; done
for v in mpm-old mpm; do r $v "dam break 1920x1080" --scene dam-break --frames 90 --size 1920x1080 --no-images; done
for v in mpm-old mpm; do r $v "dam break points 960x540" --scene dam-break --frames 90 --size 960x540 --no-images --draw points; done
# The same frames written: fixed point is deterministic run to run.
for v in mpm-old mpm; do $B/$v render --scene dam-break --frames 12 --size 480x270 --scatter fixed-point --out /tmp/png-$v > /tmp/png-$v.log 2>&1; echo "$v png rc=$?"; done
same=0 diff=0
for f in /tmp/png-mpm-old/*.png; do if cmp -s $f /tmp/png-mpm/$(basename $f); then same=$((same+1)); else diff=$((diff+1)); fi; done
echo "fixed-point PNGs: $same identical, $diff different"
cp /tmp/png-mpm/frame-00012.png $OUT/ 2>/dev/null
