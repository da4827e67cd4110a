#!/usr/bin/env bash
# Session 23 call 7: the final tree (whole waves under three waves of work, else 32 blocks a
# multiprocessor) against c2d64dc (mpm-old): the A/B table; then gpu_bodies, gpu_materials,
# gpu_solids and gpu_kernels side by side.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm PATH=$PATH:/usr/local/cuda/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
for m in mpm-old mpm; do $P/$m bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1; done
STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab1 timeout 150 bash scripts/bench-ab.sh $P/mpm-old $P/mpm \
  "--scene bench-65k" "--scene dam-break" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--scene bench-655k" "--scene dam-break --pipeline binned" > $OUT/ab.txt 2>&1
grep '^| `' $OUT/ab.txt
for f in /tmp/ab1/case*-1.log; do echo "$f $(grep -E '^\| (mirror_walls)' $f | awk -F'|' '{print $3, $8}') $(grep -E '^\| (gather_volume|g2p2g)' $f | awk -F'|' '{print $3, $8}')"; done > $OUT/phases.txt; cat $OUT/phases.txt
for t in gpu_bodies gpu_materials gpu_solids gpu_kernels; do timeout 300 $P/$t > /tmp/$t.log 2>&1 & done
wait
for t in gpu_bodies gpu_materials gpu_solids gpu_kernels; do echo "$t: $(grep 'test result' /tmp/$t.log)"; grep -E "FAILED|panicked|not run|skipp" /tmp/$t.log | head -4; done | tee $OUT/tests.txt
grep -E "RESULT|under \(Arch" /tmp/gpu_bodies.log /tmp/gpu_solids.log > $OUT/results.txt
