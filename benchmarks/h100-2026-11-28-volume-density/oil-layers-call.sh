#!/usr/bin/env bash
# Call 7: oil-on-water's layers, the build before (carried density) against this one, to 8 s.
set -u
[ -x .gpu/bin/mpm ] || { rm -rf .gpu; mkdir -p .gpu && tar xJf .gpu-pack9/pack.tar.xz -C .gpu; }
sed -n '/python3 - <<.PY./,/^PY$/p' .gpu-pack9/call6.sh | sed '1d;$d' > /tmp/plyq.py
rm -rf /tmp/e /tmp/eb
bash .gpu/run .gpu/before/mpm run --scene oil-on-water --frames 240 --backend cuda --export /tmp/e --every 120 > /tmp/eb.txt 2>&1; tail -1 /tmp/eb.txt
echo "before (carried density):"; python3 /tmp/plyq.py
rm -rf /tmp/e
bash .gpu/run .gpu/bin/mpm run --scene oil-on-water --frames 600 --backend cuda --export /tmp/e --every 120 > /tmp/ea.txt 2>&1; tail -1 /tmp/ea.txt
echo "this build (volume density):"; python3 /tmp/plyq.py
