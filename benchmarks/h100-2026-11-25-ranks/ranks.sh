#!/usr/bin/env bash
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name --format=csv,noheader
mkdir -p $OUT/r
t=$(ls .gpu/tests/gpu_ranks-*)
timeout 200 bash .gpu/run $t --nocapture --test-threads 1 > $OUT/r/ranks.log 2>&1; echo "ranks tests rc $?"; grep -E "test result|ranks:|substeps" $OUT/r/ranks.log
S=$(command -v compute-sanitizer || ls /usr/local/cuda*/bin/compute-sanitizer 2>/dev/null | head -1)
if [ -n "$S" ]; then for tool in memcheck racecheck; do timeout 250 $S --tool $tool --error-exitcode 9 $t a_dam_break_on_two_ranks --test-threads 1 > $OUT/r/san-$tool.log 2>&1; echo "$tool rc $?"; tail -3 $OUT/r/san-$tool.log; done; else echo "no compute-sanitizer"; fi
cd /tmp
timeout 120 $M render --ranks 2 --frames 30 --size 640x360 --no-images > $OUT/r/render2.log 2>&1; echo "render2 rc $?"; grep frames $OUT/r/render2.log
timeout 120 $M render --frames 30 --size 640x360 --no-images > $OUT/r/render1.log 2>&1; echo "render1 rc $?"; grep frames $OUT/r/render1.log
cd - >/dev/null
timeout 100 $M bench --scene dam-break --steps 300 --warmup 50 > $OUT/r/bench-db-1.log 2>&1; echo "bench db1 rc $?"
timeout 100 $M bench --scene dam-break --steps 300 --warmup 50 --ranks 2 > $OUT/r/bench-db-2.log 2>&1; echo "bench db2 rc $?"
timeout 100 $M bench --particles 16777216 --grid 256 --steps 100 --warmup 20 > $OUT/r/bench-16m-1.log 2>&1; echo "bench 16m1 rc $?"
timeout 150 $M bench --particles 16777216 --grid 256 --steps 100 --warmup 20 --ranks 2 > $OUT/r/bench-16m-2.log 2>&1; echo "bench 16m2 rc $?"
for f in $OUT/r/bench-*.log; do echo "== $f"; grep -E "^\| (rebin|halo|one_pass|grid_update|\*\*total)" $f | cut -c1-90; done
tar czf $OUT/ranks3.tgz -C $OUT r
