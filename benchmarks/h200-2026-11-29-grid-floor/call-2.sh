#!/usr/bin/env bash
# Session 22 call 2: split2 + the graph replay's note of the scatter's units (bodies and emitters
# refine their units again); the interior kernel four entries a step (ptx-g4) against two; GPU tests.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
$P/mpm bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1; MPM_PTX_DIR=$P/ptx-g4 $P/mpm bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1
STEPS=800 WARMUP=100 RUNS=1 OUT=/tmp/abg timeout 120 bash scripts/bench-ab.sh $P/mpm $P/mpm@$P/ptx-g4 \
  "--scene bench-65k" "--scene dam-break-1m" > $OUT/ab-g4.txt 2>&1
STEPS=200 WARMUP=50 RUNS=1 OUT=/tmp/abg16 timeout 80 bash scripts/bench-ab.sh $P/mpm $P/mpm@$P/ptx-g4 "--particles 16777216 --grid 256" >> $OUT/ab-g4.txt 2>&1
grep '^| `' $OUT/ab-g4.txt
for f in /tmp/abg/case*-1.log /tmp/abg16/case0-*-1.log; do echo "== $f"; grep 'grid_update' $f | awk -F'|' '{print $3, $8}'; done
# tests: the unit-changing graph test against the build without the fix, then everything
timeout 120 $P/gpu_kernels-unfixed graphed_substeps_match_launched_ones > $OUT/unfixed.log 2>&1; echo "unfixed: $(grep -E 'test result' $OUT/unfixed.log)"
for t in gpu_kernels gpu_lifecycle gpu_materials gpu_solids gpu_physics; do timeout 380 $P/$t > /tmp/$t.log 2>&1 & done
timeout 380 $P/gpu_bodies --skip a_sphere_settles_at_stokes_velocity --nocapture > $OUT/gpu_bodies.log 2>&1
wait
for t in gpu_kernels gpu_lifecycle gpu_materials gpu_solids gpu_physics; do echo "$t: $(grep -E 'test result' /tmp/$t.log)"; grep -E "^test .*FAILED|panicked" /tmp/$t.log | head -5; done | tee $OUT/tests.txt
echo "gpu_bodies: $(grep -E 'test result' $OUT/gpu_bodies.log)"; grep -E "FAILED|panicked" $OUT/gpu_bodies.log | head
cat /tmp/gpu_*.log > /tmp/all.log; grep -B2 -A12 "panicked" /tmp/all.log | head -60 > $OUT/failures.txt
