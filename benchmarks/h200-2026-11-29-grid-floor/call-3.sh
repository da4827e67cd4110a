#!/usr/bin/env bash
# Session 22 call 3 (issue 47): the final tree (split, side by side, water's interior four entries a
# step) against eb790ff: bytes, the A/B table, dam-break-1m headless frames; eight entries a step
# (ptx-g8) against four; ncu of the interior walk at 16.8M; gpu_kernels.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
for m in "$P/mpm-old" "$P/mpm" "env MPM_PTX_DIR=$P/ptx-g8 $P/mpm"; do $m bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1; done
OUT=/tmp/bytes timeout 120 bash .gpu-exp/split-bytes.sh $P/mpm-old $P/mpm 4 > $OUT/bytes.txt 2>&1; echo "bytes rc $?" >> $OUT/bytes.txt
tail -3 $OUT/bytes.txt
STEPS=800 WARMUP=100 RUNS=1 OUT=/tmp/ab1 timeout 150 bash scripts/bench-ab.sh $P/mpm-old $P/mpm \
  "--scene bench-65k" "--scene dam-break" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" > $OUT/ab.txt 2>&1
STEPS=200 WARMUP=50 RUNS=1 OUT=/tmp/ab16 timeout 90 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--particles 16777216 --grid 256" >> $OUT/ab.txt 2>&1
STEPS=200 WARMUP=50 RUNS=1 OUT=/tmp/ab8 timeout 90 bash scripts/bench-ab.sh $P/mpm $P/mpm@$P/ptx-g8 "--particles 16777216 --grid 256" >> $OUT/ab.txt 2>&1
grep '^| `' $OUT/ab.txt
for f in /tmp/ab1/case*-1.log /tmp/ab16/case0-*-1.log /tmp/ab8/case0-after-1.log; do echo "== $f"; grep -E '^\| (grid_update|mirror_walls|substep|total)' $f | awk -F'|' '{print $3, $6, $7, $8}'; done > $OUT/phases.txt 2>&1
grep -A1 "ab16\|ab8" $OUT/phases.txt
for m in mpm-old mpm; do echo "$m: $(timeout 60 $P/$m render --backend cuda --scene dam-break-1m --size 960x540 --frames 90 --no-images 2>&1 | tail -4 | tr '\n' ' ')"; done | tee $OUT/render.txt
timeout 150 bash scripts/ncu-kernels.sh interior16 grid_update_blocks --skip 40 --count 1 --mpm $P/mpm --out $OUT/ncu -- bench --particles 16777216 --grid 256 --steps 60 --warmup 5 > $OUT/ncu.log 2>&1; tail -6 $OUT/ncu.log
rm -f $OUT/ncu/*.ncu-rep
timeout 110 $P/gpu_kernels > $OUT/gpu_kernels.log 2>&1; echo "gpu_kernels: $(grep 'test result' $OUT/gpu_kernels.log)"
