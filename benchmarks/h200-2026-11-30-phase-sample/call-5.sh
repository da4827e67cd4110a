#!/usr/bin/env bash
# Call 5: the phases timed on one substep in 7 (new) against b0141c8 (old), one H200: the window
# (Xvfb, scripts/view-on-gpu.sh, 1280x720, one 60 Hz frame a draw), two rounds each, the panel's
# last frame of the new build; and gpu_bench, whose test now asks for every substep's phases and
# then checks the sampled table.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
timeout 90 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --out /tmp/tests --timeout 80 > $OUT/tests.txt 2>&1
tail -3 $OUT/tests.txt; grep -E "Phases timed|^\| (total|grid_update|g2p) " /tmp/tests/gpu_bench.log | head -8 >> $OUT/tests.txt
for r in 1 2; do for m in mpm-old mpm; do
  timeout 100 bash scripts/view-on-gpu.sh --frames 400 --mpm .gpu/bin/$m --x11 .gpu/x11/root.tar.xz --out /tmp/win-$m-$r > /tmp/win-$m-$r.txt 2>&1; echo "== $m round $r rc=$?"; grep -E "^viewer: (host|timed|mean)" /tmp/win-$m-$r/view.log
done; done | tee $OUT/window.txt
cp /tmp/win-mpm-1/window.png $OUT/window-mpm.png 2>/dev/null; tail -5 /tmp/win-mpm-1/check.txt > $OUT/window-check.txt 2>/dev/null
cat $OUT/tests.txt
