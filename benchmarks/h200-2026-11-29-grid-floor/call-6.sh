#!/usr/bin/env bash
# Session 22 call 6: the final tree (water's float interior walk four entries a step, fixed point
# two) against eb790ff; then every GPU test file, gpu_ranks alone first (it fails beside other GPU
# work, BENCHMARKS.md M15), Stokes' sphere in fixed point at 8 cells.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
for m in mpm-old mpm; do $P/$m bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1; done
STEPS=800 WARMUP=100 RUNS=1 OUT=/tmp/ab1 timeout 90 bash scripts/bench-ab.sh $P/mpm-old $P/mpm \
  "--scene bench-65k" "--scene dam-break" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" > $OUT/ab.txt 2>&1
STEPS=200 WARMUP=50 RUNS=1 OUT=/tmp/ab16 timeout 50 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--particles 16777216 --grid 256" >> $OUT/ab.txt 2>&1
grep '^| `' $OUT/ab.txt
for f in /tmp/ab1/case*-1.log /tmp/ab16/case0-*-1.log; do echo "$f $(grep -E '^\| (mirror_walls)' $f | awk -F'|' '{print $3, $8}')"; done > $OUT/phases.txt; cat $OUT/phases.txt
timeout 80 $P/gpu_ranks > /tmp/gpu_ranks.log 2>&1
MPM_STOKES_CELLS=8 MPM_STOKES_SCATTER=fixed-point timeout 290 $P/gpu_bodies a_sphere_settles_at_stokes_velocity --nocapture > /tmp/stokes.log 2>&1 &
timeout 290 $P/gpu_bodies --skip a_sphere_settles_at_stokes_velocity > /tmp/gpu_bodies.log 2>&1 &
for t in gpu_kernels gpu_lifecycle gpu_materials gpu_solids gpu_physics gpu_render; do timeout 290 $P/$t > /tmp/$t.log 2>&1 & done
wait
for t in gpu_ranks gpu_bodies gpu_kernels gpu_lifecycle gpu_materials gpu_solids gpu_physics gpu_render; do echo "$t: $(grep 'test result' /tmp/$t.log)"; grep -E "FAILED|panicked|not run|skipp" /tmp/$t.log | head -4; done | tee $OUT/tests.txt
grep -E "RESULT|test result|panicked" /tmp/stokes.log | tee $OUT/stokes.txt
grep -E "RESULT|under \(Arch" /tmp/gpu_bodies.log /tmp/gpu_solids.log > $OUT/results.txt
