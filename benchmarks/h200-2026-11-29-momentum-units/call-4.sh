#!/usr/bin/env bash
# Session 21 call 4: issue 47's split (branch gridsplit at ebf3389) under the GPU tests; main's gpu_bodies
# (without Stokes, run in call 2); float_ranks_follow_one_gpu three times on 1dabe4d (mpm-old in the pack is its gpu_ranks) and on main.
set -u
S=/tmp/ps; mkdir -p $S && tar -xJf .gpu-exp/split-pack.tar.xz -C $S --strip-components=1
P=/tmp/p4; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
for t in gpu_kernels gpu_physics gpu_solids gpu_ranks gpu_lifecycle gpu_materials gpu_bodies; do
  (MPM_BIN=$S/mpm timeout 300 $S/$t --skip a_sphere_settles_at_stokes_velocity > /tmp/split-$t.log 2>&1; echo "rc=$?" >> /tmp/split-$t.log) &
done
(MPM_BIN=$P/mpm timeout 300 $P/gpu_bodies --skip a_sphere_settles_at_stokes_velocity > /tmp/main-gpu_bodies.log 2>&1; echo "rc=$?" >> /tmp/main-gpu_bodies.log) &
wait
for i in 1 2 3; do timeout 100 $P/gpu_ranks float_ranks_follow_one_gpu --nocapture 2>&1 | grep -E "dx from|^test result" | sed "s/^/main $i: /"; done > $OUT/ranks-flake.txt
for i in 1 2 3; do timeout 100 $P/mpm-old float_ranks_follow_one_gpu --nocapture 2>&1 | grep -E "dx from|^test result" | sed "s/^/old $i: /"; done >> $OUT/ranks-flake.txt
cat /tmp/split-*.log > $OUT/split-tests.log; cp /tmp/main-gpu_bodies.log $OUT/
for t in gpu_kernels gpu_physics gpu_solids gpu_ranks gpu_lifecycle gpu_materials gpu_bodies; do
  echo "== split $t"; grep -E "^test result|FAILED|panicked|rc=" /tmp/split-$t.log | head -8
done
echo "== main gpu_bodies"; grep -E "^test result|FAILED|panicked|rc=" /tmp/main-gpu_bodies.log | head -8
cat $OUT/ranks-flake.txt
