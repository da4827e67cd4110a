#!/usr/bin/env bash
# Device call 3 (issue 42): boats ran 37 % slower a substep than on 2026-11-28 (0.170 against
# 0.124 ms): the phase tables of boats before (5602c5d) and after, and step_bodies' own time (ncu)
# in boats and the pile bench; then --export-bodies on the GPU.
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p3; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
for r in 1 2; do for b in mpm-old mpm; do
  timeout 60 $P/$b bench --scene boats --steps 1000 > $L/boats-$b-$r.txt 2>&1
  grep -E "^\| (mirror_walls|gather_volume|\*\*total)" $L/boats-$b-$r.txt | awk -F'|' -v n="$b $r" '{print n, substr($2,1,30), $3}'
done; done
NCU=$(command -v ncu || ls /usr/local/cuda*/bin/ncu 2>/dev/null | head -1)
for s in boats benches/scenes/bench-boxes-pile.toml; do
  timeout 120 $NCU --clock-control none --kernel-name step_bodies --launch-skip 400 --launch-count 5 --metrics gpu__time_duration.sum $P/mpm run --scene $s --frames 12 > $L/ncu-$(basename $s .toml).txt 2>&1
  grep -E "gpu__time_duration" $L/ncu-$(basename $s .toml).txt | head -5 | sed "s|^|$(basename $s .toml): |"
done
mkdir -p /tmp/eb; timeout 60 $P/mpm run --scene ball-drop --frames 12 --export-bodies /tmp/eb --every 4 > $L/export-bodies.txt 2>&1; tail -1 $L/export-bodies.txt | cut -c1-200; ls /tmp/eb; cp /tmp/eb/bodies.csv /tmp/eb/bodies_000012.obj $L/ 2>/dev/null
tar -czf $OUT/logs.tgz -C $L . && rm -rf $L
