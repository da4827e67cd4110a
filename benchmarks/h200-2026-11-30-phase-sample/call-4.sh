#!/usr/bin/env bash
# Call 4 (the session's fourth device call): the phases timed on one substep in 7 (new) against
# b0141c8 (old, every substep's phases), one H200: bench A/B, headless frames, fixed-point bytes
# (nothing the kernels do changed), and the GPU tests that read the timings.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
OLD=.gpu/bin/mpm-old NEW=.gpu/bin/mpm
OUT=$OUT/ab STEPS=1000 WARMUP=100 RUNS=2 timeout 200 bash scripts/bench-ab.sh $OLD $NEW \
  "--scene bench-65k" "--scene dam-break" "--scene dam-break --scatter fixed-point" "--scene dam-break-1m" "--scene bench-655k" > $OUT/ab.txt 2>&1
OUT=$OUT/ab16 STEPS=200 WARMUP=50 RUNS=1 timeout 80 bash scripts/bench-ab.sh $OLD $NEW "--particles 16777216 --grid 256" > $OUT/ab16.txt 2>&1
for run in 1 2; do for bin in mpm-old mpm; do for scene in dam-break dam-break-1m; do
  timeout 60 .gpu/bin/$bin render --backend cuda --scene $scene --frames 90 --size 960x540 --no-images 2>&1 | tail -3 | sed "s|^|$bin $scene $run: |" >> $OUT/render.txt
done; done; done
timeout 90 bash benchmarks/h200-2026-11-29-grid-floor/split-bytes.sh $OLD $NEW 6 > $OUT/bytes.txt 2>&1
cat $OUT/ab.txt $OUT/ab16.txt $OUT/render.txt; tail -4 $OUT/bytes.txt
timeout 200 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --out $OUT/tests --timeout 190 > $OUT/tests.txt 2>&1
tail -9 $OUT/tests.txt
