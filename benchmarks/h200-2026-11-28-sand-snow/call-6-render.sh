#!/usr/bin/env bash
# Device call 6: the snowball preset drawn by mpm render, alone on the GPU (its cost a frame), and
# frames for the docs' picture.
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p6; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
for f in $P/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p /tmp/snow
timeout 400 $P/mpm render --scene snowball --frames 30 --size 1280x720 --colour material --out /tmp/snow 2>&1 | grep -v "^frame"
mkdir -p $OUT/png; for f in 3 6 9 15 30; do cp /tmp/snow/frame-$(printf %05d $f).png $OUT/png/; done
