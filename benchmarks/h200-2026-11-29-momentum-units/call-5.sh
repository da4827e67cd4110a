#!/usr/bin/env bash
# Session 21 call 5: main at fa5577c (bodies keep the coarse units): gpu_bodies without Stokes, the
# vortex in fixed point, Stokes 8 cells float.
set -u
P=/tmp/p5; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P --strip-components=1
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
(timeout 330 $P/gpu_bodies --skip a_sphere_settles_at_stokes_velocity > $OUT/gpu_bodies.log 2>&1; echo "rc=$?" >> $OUT/gpu_bodies.log) &
(timeout 200 $P/gpu_materials a_box_vortex_decays_at_its_viscous_rate_in_fixed_point > $OUT/vortex.log 2>&1; echo "rc=$?" >> $OUT/vortex.log) &
(MPM_STOKES_CELLS=8 timeout 330 $P/gpu_bodies a_sphere_settles_at_stokes_velocity --nocapture 2>&1 | grep -v "distance field" > $OUT/stokes8.log; echo "rc=$?" >> $OUT/stokes8.log) &
wait
grep -E "^test result|FAILED|panicked|rc=|fixed-point: CPU" $OUT/gpu_bodies.log | head; grep -E "^RESULT.*0.0025 m, 150" $OUT/gpu_bodies.log
grep -E "^test result|rc=" $OUT/vortex.log; grep -E "RESULT|^test result" $OUT/stokes8.log
