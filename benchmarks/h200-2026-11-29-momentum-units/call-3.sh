#!/usr/bin/env bash
# Session 21 call 3 (issue 42): momentum units from the flow's speed, the fused pipeline's grid update
# reading the sums in the units they were scattered in. Tests concurrently, then the A/B alone.
set -u
P=/tmp/p3; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P --strip-components=1
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
(timeout 300 $P/gpu_materials a_box_vortex_decays_at_its_viscous_rate --nocapture > $OUT/vortex.log 2>&1; echo "rc=$?" >> $OUT/vortex.log) &
(timeout 400 $P/gpu_lifecycle > $OUT/gpu_lifecycle.log 2>&1; echo "rc=$?" >> $OUT/gpu_lifecycle.log) &
(timeout 400 $P/gpu_ranks > $OUT/gpu_ranks.log 2>&1; echo "rc=$?" >> $OUT/gpu_ranks.log) &
(timeout 400 $P/gpu_kernels > $OUT/gpu_kernels.log 2>&1; echo "rc=$?" >> $OUT/gpu_kernels.log) &
(timeout 400 $P/gpu_physics > $OUT/gpu_physics.log 2>&1; echo "rc=$?" >> $OUT/gpu_physics.log) &
(timeout 400 $P/gpu_solids > $OUT/gpu_solids.log 2>&1; echo "rc=$?" >> $OUT/gpu_solids.log) &
wait
for f in vortex gpu_lifecycle gpu_ranks gpu_kernels gpu_physics gpu_solids; do echo "== $f"; grep -E "^test result|FAILED|panicked|rc=|RESULT|decay" $OUT/$f.log | head -12; done
STEPS=800 WARMUP=100 RUNS=1 OUT=/tmp/ab3 timeout 150 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene dam-break --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break-1m --scatter fixed-point" > $OUT/ab.txt 2>&1
grep '^|' $OUT/ab.txt
