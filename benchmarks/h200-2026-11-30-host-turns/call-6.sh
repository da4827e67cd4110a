#!/usr/bin/env bash
# Session 24 call 6: graph executables updated in place (production code) and the viewer's GPU gate
# (MPM_VIEW_GATE=0 turns it off in this build) against acfda89 (mpm-old): the window, headless
# render, A/B, bytes, GPU tests.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm PATH=$PATH:/usr/local/cuda/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
printf '#!/bin/sh\nMPM_VIEW_GATE=0 exec %s "$@"\n' $P/mpm > $P/mpm-nogate; chmod +x $P/mpm-nogate
for r in 1 2; do for m in mpm-old mpm mpm-nogate; do
  timeout 100 bash scripts/view-on-gpu.sh --frames 400 --mpm $P/$m --x11 .gpu/x11/root.tar.xz --out /tmp/win-$m-$r > /tmp/win-$m-$r.txt 2>&1; echo "== $m round $r rc=$?"; grep -E "^viewer: (host|timed|mean)" /tmp/win-$m-$r/view.log
done; done | tee $OUT/window.txt
cp /tmp/win-mpm-1/window.png $OUT/window-mpm.png 2>/dev/null; tail -5 /tmp/win-mpm-1/check.txt > $OUT/window-check.txt 2>/dev/null
STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab1 timeout 150 bash scripts/bench-ab.sh $P/mpm-old $P/mpm \
  "--scene bench-65k" "--scene dam-break" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--scene bench-655k" > $OUT/ab.txt 2>&1
grep '^| `' $OUT/ab.txt
for f in /tmp/ab1/case*.log; do echo "$f $(grep -o 'Wall clock: [0-9.]*' $f)"; done | tee $OUT/wall.txt
for s in dam-break dam-break-1m; do for m in mpm-old mpm mpm-old mpm; do echo "$m $s: $(timeout 60 $P/$m render --backend cuda --scene $s --size 960x540 --frames 90 --no-images 2>&1 | grep -E 'sim .* ms' | tr '\n' ' ')"; done; done | tee $OUT/render.txt
OUT=/tmp/bytes timeout 150 bash .gpu-exp/split-bytes.sh $P/mpm-old $P/mpm 3 > /tmp/bytes.txt 2>&1; echo "bytes rc $?" >> /tmp/bytes.txt; tail -12 /tmp/bytes.txt | tee $OUT/bytes.txt
# (tests: next call)


