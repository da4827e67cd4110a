#!/usr/bin/env bash
# Session 24 call 1: the timing tap (captured substeps' timing events on a branch off the chain)
# against acfda89 (mpm-old): A/B with wall clock, dam-break-1m render, fixed-point bytes, tests.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm PATH=$PATH:/usr/local/cuda/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
for m in mpm-old mpm; do $P/$m bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1; done
$P/mpm bench --scene bench-65k --steps 50 --warmup 10 > $OUT/smoke.txt 2>&1; tail -3 $OUT/smoke.txt
STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab1 timeout 170 bash scripts/bench-ab.sh $P/mpm-old $P/mpm \
  "--scene bench-65k" "--scene dam-break" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--scene bench-655k" > $OUT/ab.txt 2>&1
grep '^| `' $OUT/ab.txt
STEPS=200 WARMUP=50 RUNS=1 OUT=/tmp/ab2 timeout 60 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--particles 16777216 --grid 256" > $OUT/ab16.txt 2>&1
grep '^| `' $OUT/ab16.txt
for f in /tmp/ab1/case*.log /tmp/ab2/case*.log; do echo "$f $(grep -E '^\| (mirror_walls)' $f | awk -F'|' '{print $3}') $(grep -E '^\| (gather_volume|g2p2g)' $f | awk -F'|' '{print $3}') $(grep -o 'Wall clock: [0-9.]*' $f)"; done > $OUT/phases.txt; cat $OUT/phases.txt
for r in 1 2; do for m in mpm-old mpm; do echo "$m round $r: $(timeout 60 $P/$m render --backend cuda --scene dam-break-1m --size 960x540 --frames 90 --no-images 2>&1 | grep -E 'sim .* ms' | tr '\n' ' ')"; done; done | tee $OUT/render.txt
OUT=/tmp/bytes timeout 150 bash .gpu-exp/split-bytes.sh $P/mpm-old $P/mpm 3 > /tmp/bytes.txt 2>&1; echo "bytes rc $?" >> /tmp/bytes.txt; tail -12 /tmp/bytes.txt | tee $OUT/bytes.txt
for t in gpu_kernels gpu_lifecycle gpu_physics gpu_render; do timeout 150 $P/$t > /tmp/$t.log 2>&1 & done
wait
for t in gpu_kernels gpu_lifecycle gpu_physics gpu_render; do echo "$t: $(grep 'test result' /tmp/$t.log)"; grep -E "FAILED|panicked|not run|skipp" /tmp/$t.log | head -4; done | tee $OUT/tests.txt
