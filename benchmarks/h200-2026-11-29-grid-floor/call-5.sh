#!/usr/bin/env bash
# Session 22 call 5 (issue 47): water's float interior walk, four variants in one call: contiguous
# groups of 4 (ptx-c4) and of 8 (embedded), strided groups of 4 (ptx-s4) and of 8 (ptx-s8).
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
ls $P
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
for v in c4 s4 s8; do MPM_PTX_DIR=$P/ptx-$v $P/mpm bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1; done
cases=("--scene bench-65k" "--scene dam-break" "--scene dam-break-1m")
STEPS=800 WARMUP=100 RUNS=1 OUT=/tmp/a timeout 120 bash scripts/bench-ab.sh $P/mpm@$P/ptx-c4 $P/mpm@$P/ptx-s8 "${cases[@]}" > $OUT/c4-s8.txt 2>&1
STEPS=800 WARMUP=100 RUNS=1 OUT=/tmp/b timeout 120 bash scripts/bench-ab.sh $P/mpm $P/mpm@$P/ptx-s4 "${cases[@]}" > $OUT/c8-s4.txt 2>&1
STEPS=200 WARMUP=50 RUNS=1 OUT=/tmp/c timeout 80 bash scripts/bench-ab.sh $P/mpm@$P/ptx-c4 $P/mpm@$P/ptx-s8 "--particles 16777216 --grid 256" >> $OUT/c4-s8.txt 2>&1
STEPS=200 WARMUP=50 RUNS=1 OUT=/tmp/d timeout 80 bash scripts/bench-ab.sh $P/mpm $P/mpm@$P/ptx-s4 "--particles 16777216 --grid 256" >> $OUT/c8-s4.txt 2>&1
echo "c4 -> s8"; grep '^| `' $OUT/c4-s8.txt; echo "c8 -> s4"; grep '^| `' $OUT/c8-s4.txt
for f in /tmp/[abcd]/case*-1.log; do echo "$f $(grep -E '^\| (mirror_walls)' $f | awk -F'|' '{print $3, $8}')"; done | tee $OUT/phases.txt
