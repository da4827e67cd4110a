#!/usr/bin/env bash
# Session 24 call 3: phase events on every 8th substep only (start and end on all; MPM_PHASE_SAMPLE=8)
# against acfda89 (mpm-old), and the same build at every substep.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm PATH=$PATH:/usr/local/cuda/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
printf '#!/bin/sh\nMPM_PHASE_SAMPLE=8 exec %s "$@"\n' $P/mpm > $P/mpm-s8; chmod +x $P/mpm-s8
for m in mpm-old mpm; do $P/$m bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1; done
STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab1 timeout 150 bash scripts/bench-ab.sh $P/mpm-old $P/mpm-s8 \
  "--scene bench-65k" "--scene dam-break" "--scene dam-break-1m" "--scene bench-655k" "--scene dam-break --scatter fixed-point" > $OUT/ab.txt 2>&1
grep '^| `' $OUT/ab.txt
STEPS=1000 WARMUP=100 RUNS=1 OUT=/tmp/ab0 timeout 60 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene bench-65k" "--scene dam-break" > $OUT/ab0.txt 2>&1
grep '^| `' $OUT/ab0.txt
for f in /tmp/ab1/case0*.log; do echo "$f $(grep -o 'Wall clock: [0-9.]*' $f)"; done
for r in 1 2; do for m in mpm-old mpm-s8; do echo "$m round $r: $(timeout 60 $P/$m render --backend cuda --scene dam-break-1m --size 960x540 --frames 90 --no-images 2>&1 | grep -E 'sim .* ms' | tr '\n' ' ')"; done; done | tee $OUT/render.txt
