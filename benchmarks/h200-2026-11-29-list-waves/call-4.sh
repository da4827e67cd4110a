#!/usr/bin/env bash
# Session 23 call 4: the list passes' blocks from the kernel's residency (the final tree) against
# c2d64dc (mpm-old): the A/B table, fixed-point bytes over 9 scenes, issue 42's ten-bodies bound on
# this build, then every GPU test file (gpu_ranks alone first).
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm PATH=$PATH:/usr/local/cuda/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
for m in mpm-old mpm; do $P/$m bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1; done
STEPS=1500 WARMUP=100 RUNS=2 OUT=/tmp/ab1 timeout 200 bash scripts/bench-ab.sh $P/mpm-old $P/mpm \
  "--scene bench-65k" "--scene dam-break" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--scene bench-655k" "--scene dam-break --pipeline binned" > $OUT/ab.txt 2>&1
STEPS=200 WARMUP=50 RUNS=2 OUT=/tmp/ab16 timeout 150 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--particles 16777216 --grid 256" "--particles 16777216 --grid 256 --scatter fixed-point" >> $OUT/ab.txt 2>&1
grep '^| `' $OUT/ab.txt
for f in /tmp/ab1/case*-1.log /tmp/ab16/case*-1.log; do echo "$f $(grep -E '^\| (mirror_walls)' $f | awk -F'|' '{print $3, $8}') $(grep -E '^\| (gather_volume|g2p2g)' $f | awk -F'|' '{print $3, $8}')"; done > $OUT/phases.txt; cat $OUT/phases.txt
B=benches/scenes
for r in 1 2; do for s in bodies static; do
  timeout 60 $P/mpm bench --scene $B/bench-boxes-$s.toml --steps 1000 > /tmp/boxes-$s-$r.txt 2>&1
  echo "boxes-$s round $r: $(grep -E '^\| \*\*total' /tmp/boxes-$s-$r.txt)"
done; done | tee $OUT/boxes.txt
OUT=/tmp/bytes timeout 150 bash .gpu-exp/split-bytes.sh $P/mpm-old $P/mpm 4 > /tmp/bytes.txt 2>&1; echo "bytes rc $?" >> /tmp/bytes.txt; tail -12 /tmp/bytes.txt | tee $OUT/bytes.txt
timeout 80 $P/gpu_ranks > /tmp/gpu_ranks.log 2>&1
timeout 260 $P/gpu_bodies > /tmp/gpu_bodies.log 2>&1 &
for t in gpu_kernels gpu_lifecycle gpu_materials gpu_solids gpu_physics gpu_render; do timeout 260 $P/$t > /tmp/$t.log 2>&1 & done
wait
for t in gpu_ranks gpu_bodies gpu_kernels gpu_lifecycle gpu_materials gpu_solids gpu_physics gpu_render; do echo "$t: $(grep 'test result' /tmp/$t.log)"; grep -E "FAILED|panicked|not run|skipp" /tmp/$t.log | head -4; done | tee $OUT/tests.txt
