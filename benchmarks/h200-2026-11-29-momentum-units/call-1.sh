#!/usr/bin/env bash
# Session 21 call 1 (issue 42): momentum units from the flow's speed. Tests concurrently, then the A/B alone.
set -u
P=/tmp/p1; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P --strip-components=1
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
(timeout 300 $P/gpu_materials a_box_vortex_decays_at_its_viscous_rate_in_fixed_point --nocapture > $OUT/vortex-fixed.log 2>&1; echo "rc=$?" >> $OUT/vortex-fixed.log) &
(MPM_STOKES_CELLS=8 MPM_STOKES_SCATTER=fixed-point timeout 400 $P/gpu_bodies a_sphere_settles_at_stokes_velocity --nocapture > $OUT/stokes8-fixed.log 2>&1; echo "rc=$?" >> $OUT/stokes8-fixed.log) &
(timeout 300 $P/gpu_lifecycle > $OUT/gpu_lifecycle.log 2>&1; echo "rc=$?" >> $OUT/gpu_lifecycle.log) &
wait
tail -4 $OUT/vortex-fixed.log $OUT/gpu_lifecycle.log; grep -E "mm/s|%|rc=" $OUT/stokes8-fixed.log | tail -6
STEPS=800 WARMUP=100 RUNS=1 OUT=/tmp/ab1 timeout 200 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene dam-break" "--scene dam-break --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break-1m --scatter fixed-point" > $OUT/ab.txt 2>&1
grep '^|' $OUT/ab.txt
