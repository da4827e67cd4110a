#!/usr/bin/env bash
# Session 24 call 7: the final build (graph executables updated in place; the viewer's GPU gate)
# against acfda89 (mpm-old): A/B in three rounds, fixed-point bytes, GPU tests, gpu_bodies alone.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm PATH=$PATH:/usr/local/cuda/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
for m in mpm-old mpm; do $P/$m bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1; done
STEPS=1000 WARMUP=100 RUNS=3 OUT=/tmp/ab1 timeout 200 bash scripts/bench-ab.sh $P/mpm-old $P/mpm \
  "--scene bench-65k" "--scene dam-break" "--scene dam-break --scatter fixed-point" "--scene dam-break-1m" "--scene bench-655k" > $OUT/ab.txt 2>&1
grep '^| `' $OUT/ab.txt
for f in /tmp/ab1/case*.log; do echo "$f $(grep -E '^\| (mirror_walls)' $f | awk -F'|' '{print $3}') $(grep -E '^\| (gather_volume|g2p2g)' $f | awk -F'|' '{print $3}') $(grep -o 'Wall clock: [0-9.]*' $f)"; done | tee $OUT/phases.txt
STEPS=200 WARMUP=50 RUNS=1 OUT=/tmp/ab2 timeout 60 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--particles 16777216 --grid 256" > $OUT/ab16.txt 2>&1
grep '^| `' $OUT/ab16.txt
OUT=/tmp/bytes timeout 150 bash .gpu-exp/split-bytes.sh $P/mpm-old $P/mpm 3 > /tmp/bytes.txt 2>&1; echo "bytes rc $?" >> /tmp/bytes.txt; tail -3 /tmp/bytes.txt | tee $OUT/bytes.txt
for t in gpu_kernels gpu_lifecycle gpu_physics gpu_render; do timeout 200 $P/$t > /tmp/$t.log 2>&1 & done
wait
timeout 280 $P/gpu_bodies > /tmp/gpu_bodies.log 2>&1
for t in gpu_kernels gpu_lifecycle gpu_physics gpu_render gpu_bodies; do echo "$t: $(grep 'test result' /tmp/$t.log)"; grep -E "FAILED|panicked|not run|skipp" /tmp/$t.log | head -4; done | tee $OUT/tests.txt
cp /tmp/gpu_bodies.log /tmp/gpu_render.log $OUT/
