#!/usr/bin/env bash
# Session 24 call 5: graph update in place, with (MPM_GRAPH_UPDATE=2) and without (=1) an upload
# after each update, against acfda89 (mpm-old); headless render; the window (Xvfb).
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm PATH=$PATH:/usr/local/cuda/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
for u in 1 2; do printf '#!/bin/sh\nMPM_GRAPH_UPDATE=%s exec %s "$@"\n' $u $P/mpm > $P/mpm-upd$u; chmod +x $P/mpm-upd$u; done
STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab1 timeout 150 bash scripts/bench-ab.sh $P/mpm-old $P/mpm-upd2 \
  "--scene bench-65k" "--scene dam-break" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" > $OUT/ab.txt 2>&1
grep '^| `' $OUT/ab.txt
STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab2 timeout 100 bash scripts/bench-ab.sh $P/mpm-upd1 $P/mpm-upd2 "--scene bench-65k" "--scene dam-break" > $OUT/ab12.txt 2>&1
grep '^| `' $OUT/ab12.txt
for f in /tmp/ab1/case*.log /tmp/ab2/case*.log; do echo "$f $(grep -o 'Wall clock: [0-9.]*' $f)"; done | tee $OUT/wall.txt
for s in dam-break dam-break-1m; do for m in mpm-old mpm-upd2 mpm-old mpm-upd2; do echo "$m $s: $(timeout 60 $P/$m render --backend cuda --scene $s --size 960x540 --frames 90 --no-images 2>&1 | grep -E 'sim .* ms' | tr '\n' ' ')"; done; done | tee $OUT/render.txt
for r in 1 2; do for m in mpm-old mpm-upd2; do
  timeout 100 bash scripts/view-on-gpu.sh --frames 400 --mpm $P/$m --x11 .gpu/x11/root.tar.xz --out /tmp/win-$m-$r > /tmp/win-$m-$r.txt 2>&1; echo "== $m round $r rc=$?"; grep -E "^viewer: (host|timed|mean)" /tmp/win-$m-$r/view.log
done; done | tee $OUT/window.txt
cp /tmp/win-mpm-upd2-1/window.png $OUT/window-upd2.png 2>/dev/null
