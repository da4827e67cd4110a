#!/usr/bin/env bash
# Session 22 call 1 (issue 47): the wall/interior split rebased on eb790ff, its two launches side by
# side (split2), against eb790ff: fixed-point bytes, one A/B round, GPU tests.
set -u
P=/tmp/p; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
# warm the driver's PTX cache for both builds
$P/mpm-old bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1; $P/mpm bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1
OUT=/tmp/bytes timeout 200 bash .gpu-exp/split-bytes.sh $P/mpm-old $P/mpm 6 > $OUT/bytes.txt 2>&1; echo "bytes rc $?" >> $OUT/bytes.txt
cat $OUT/bytes.txt
STEPS=800 WARMUP=100 RUNS=1 OUT=/tmp/ab1 timeout 150 bash scripts/bench-ab.sh $P/mpm-old $P/mpm \
  "--scene bench-65k" "--scene dam-break" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" > $OUT/ab.txt 2>&1
grep '^| `' $OUT/ab.txt
STEPS=200 WARMUP=50 RUNS=1 OUT=/tmp/ab16 timeout 100 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--particles 16777216 --grid 256" > $OUT/ab16.txt 2>&1
grep '^| `' $OUT/ab16.txt
# the phase tables of the after side
for f in /tmp/ab1/case*-after-1.log /tmp/ab16/case0-after-1.log; do echo "== $f"; grep '^|' $f; done > $OUT/phases.txt
grep -E "^==|grid_update" $OUT/phases.txt
timeout 200 $P/gpu_kernels > $OUT/gpu_kernels.log 2>&1 &
timeout 200 $P/gpu_lifecycle > $OUT/gpu_lifecycle.log 2>&1 &
timeout 200 $P/gpu_bodies --skip a_sphere_settles_at_stokes_velocity > $OUT/gpu_bodies.log 2>&1 &
wait
for t in gpu_kernels gpu_lifecycle gpu_bodies; do echo "$t: $(grep -E 'passed|failed' $OUT/$t.log | tail -2 | tr '\n' ' ')"; done
