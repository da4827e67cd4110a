#!/usr/bin/env bash
# Session 22 call 4 (issues 47 and 42): the final tree (water's interior kernels by scatter: float
# eight entries a step, fixed point two) against eb790ff: bytes, the A/B table, dam-break-1m's
# frames; then GPU tests: the light log at 1.25 mm, the floating block in fixed point.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
for m in mpm-old mpm; do $P/$m bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1; done
OUT=/tmp/bytes timeout 120 bash .gpu-exp/split-bytes.sh $P/mpm-old $P/mpm 4 > $OUT/bytes.txt 2>&1; echo "bytes rc $?" >> $OUT/bytes.txt
grep -v "same bytes" $OUT/bytes.txt | cut -c1-80
STEPS=800 WARMUP=100 RUNS=1 OUT=/tmp/ab1 timeout 150 bash scripts/bench-ab.sh $P/mpm-old $P/mpm \
  "--scene bench-65k" "--scene dam-break" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" > $OUT/ab.txt 2>&1
STEPS=200 WARMUP=50 RUNS=1 OUT=/tmp/ab16 timeout 90 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--particles 16777216 --grid 256" >> $OUT/ab.txt 2>&1
grep '^| `' $OUT/ab.txt
for f in /tmp/ab1/case*-1.log /tmp/ab16/case0-*-1.log; do echo "== $f"; grep -E '^\| (grid_update|mirror_walls)' $f | awk -F'|' '{print $3, $6, $7, $8}'; done > $OUT/phases.txt 2>&1
cat $OUT/phases.txt | paste - - 
for m in mpm-old mpm mpm-old mpm; do echo "$m: $(timeout 60 $P/$m run --backend cuda --scene dam-break-1m --frames 120 2>&1 | grep -E '^time:')"; done | tee $OUT/run1m.txt
MPM_LOGS_DX=0.00125 MPM_LOGS_DENSITIES=150 timeout 300 $P/gpu_bodies logs_float_at_their_draft --nocapture > $OUT/logs125.log 2>&1 &
MPM_BLOCKS_SCATTER=fixed-point timeout 300 $P/gpu_solids blocks_float_and_sink --nocapture > $OUT/blocks-fp.log 2>&1 &
timeout 200 $P/gpu_kernels > /tmp/gpu_kernels.log 2>&1 &
timeout 200 $P/gpu_lifecycle > /tmp/gpu_lifecycle.log 2>&1 &
wait
for t in gpu_kernels gpu_lifecycle; do echo "$t: $(grep 'test result' /tmp/$t.log)"; grep -E "FAILED|panicked" /tmp/$t.log | head -3; done
grep -E "RESULT|test result|panicked" $OUT/logs125.log; grep -E "under|test result|panicked" $OUT/blocks-fp.log
