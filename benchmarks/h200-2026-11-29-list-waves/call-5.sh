#!/usr/bin/env bash
# Session 23 call 5: the window (dam break, one frame a draw, 1280x720, 400 draws, a real X window
# under Xvfb with the NVIDIA GLX) and dam-break-1m headless, c2d64dc (mpm-old) against the tree; then
# the list passes in whole waves against c2d64dc: the A/B table, fixed-point bytes, gpu_kernels.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm PATH=$PATH:/usr/local/cuda/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
R=/tmp/view; mkdir -p $R
for r in 1 2; do for v in mpm-old mpm; do
  timeout 60 bash scripts/view-on-gpu.sh --frames 400 --mpm $P/$v --x11 .gpu/x11/root.tar.xz --out $R/$v-$r > $R/$v-$r.script.log 2>&1
  echo "== $v round $r rc=$?"; grep "^viewer:" $R/$v-$r/view.log | grep -v "frames drawn"; grep -i "fail" $R/$v-$r/check.txt 2>/dev/null | head -3
done; done 2>&1 | tee $OUT/window.txt
cp $R/mpm-1/window.png $OUT/window-mpm-1.png 2>/dev/null
for r in 1 2; do for m in mpm-old mpm; do echo "$m round $r: $(timeout 60 $P/$m render --backend cuda --scene dam-break-1m --size 960x540 --frames 90 --no-images 2>&1 | grep -E 'sim .* ms' | tr '\n' ' ')"; done; done | tee $OUT/render.txt
STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab1 timeout 150 bash scripts/bench-ab.sh $P/mpm-old $P/mpm \
  "--scene bench-65k" "--scene dam-break" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--scene bench-655k" "--scene dam-break --pipeline binned" > $OUT/ab.txt 2>&1
STEPS=200 WARMUP=50 RUNS=2 OUT=/tmp/ab16 timeout 120 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--particles 16777216 --grid 256" "--particles 16777216 --grid 256 --scatter fixed-point" >> $OUT/ab.txt 2>&1
grep '^| `' $OUT/ab.txt
for f in /tmp/ab1/case*-1.log /tmp/ab16/case*-1.log; do echo "$f $(grep -E '^\| (mirror_walls)' $f | awk -F'|' '{print $3, $8}') $(grep -E '^\| (gather_volume|g2p2g)' $f | awk -F'|' '{print $3, $8}')"; done > $OUT/phases.txt; cat $OUT/phases.txt
OUT=/tmp/bytes timeout 60 bash .gpu-exp/split-bytes.sh $P/mpm-old $P/mpm 3 > /tmp/bytes.txt 2>&1; echo "bytes rc $?" >> /tmp/bytes.txt; tail -3 /tmp/bytes.txt | tee $OUT/bytes.txt
timeout 90 $P/gpu_kernels > /tmp/gpu_kernels.log 2>&1; echo "gpu_kernels: $(grep 'test result' /tmp/gpu_kernels.log)" | tee $OUT/tests.txt
