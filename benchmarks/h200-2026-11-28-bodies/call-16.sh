#!/usr/bin/env bash
# Device call 16 (issue 42): the presets ball-drop and boats run headless (their cost a frame and
# the bodies' poses a frame, --stats), and drawn by mpm render for the docs' pictures.
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p16; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
for f in $P/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
L=$OUT/logs; mkdir -p $L
timeout 150 $P/mpm run --scene ball-drop --frames 120 --stats $L/ball-drop.jsonl > $L/ball-drop-run.txt 2>&1; tail -3 $L/ball-drop-run.txt | cut -c1-300
timeout 200 $P/mpm run --scene boats --frames 300 --stats $L/boats.jsonl > $L/boats-run.txt 2>&1; tail -3 $L/boats-run.txt | cut -c1-300
mkdir -p /tmp/ball /tmp/boats
timeout 120 $P/mpm render --scene ball-drop --frames 24 --size 1280x720 --out /tmp/ball > $L/ball-render.txt 2>&1; tail -2 $L/ball-render.txt
timeout 150 $P/mpm render --scene boats --frames 150 --size 1280x720 --out /tmp/boats > $L/boats-render.txt 2>&1; tail -2 $L/boats-render.txt
mkdir -p $OUT/png; for f in 8 12 16 24; do cp /tmp/ball/frame-$(printf %05d $f).png $OUT/png/ball-$f.png; done; for f in 90 150; do cp /tmp/boats/frame-$(printf %05d $f).png $OUT/png/boats-$f.png; done
tar -czf $OUT/logs.tgz -C $L . && rm -rf $L
