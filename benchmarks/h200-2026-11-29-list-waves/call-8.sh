#!/usr/bin/env bash
# Session 23 call 8: gpu_bodies on the final tree without its two long tests (call 7 ran all six side by side
# with three other test files and stopped at 300 s, in the logs test's 1.25 mm run).
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1 && export MPM_BIN=$P/mpm && timeout 160 $P/gpu_bodies --skip logs_float_at_their_draft_and_angle_at_finer_cells --skip a_sphere_settles_at_stokes_velocity > $OUT/gpu_bodies.log 2>&1
