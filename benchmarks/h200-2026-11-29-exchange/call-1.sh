#!/usr/bin/env bash
# Device call 1 (issue 42, ten bodies at 5.9 % of a substep): the bodies' exchange summed per CUDA
# block in shared memory (one global atomic a block a sum), and find_contacts testing the collider
# slots' reach a lane a slot. mpm-old is e675757; mpm@ptx-gu has only the grid update's change,
# mpm@ptx-bod only step_bodies'. Bench rows, water alone A/B, ncu source-level stalls of both
# kernels, gpu_bodies and gpu_lifecycle.
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p1; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_* $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
B=benches/scenes
row() { echo "$1: $(grep -E '^\| mirror_walls' $2 | awk -F'|' '{print "grid", $3}') $(grep -E '^\| \*\*total' $2 | awk -F'|' '{print "total", $3}')"; }
for r in 1 2; do
  for s in boxes-static boxes-bodies; do for b in mpm-old mpm; do
    timeout 60 $P/$b bench --scene $B/bench-$s.toml --steps 1000 > $L/$b-$s-$r.txt 2>&1; row "$b $s $r" $L/$b-$s-$r.txt
  done; done
  for v in gu bod; do
    MPM_PTX_DIR=$P/ptx-$v timeout 60 $P/mpm bench --scene $B/bench-boxes-bodies.toml --steps 1000 > $L/ptx-$v-boxes-bodies-$r.txt 2>&1; row "ptx-$v boxes-bodies $r" $L/ptx-$v-boxes-bodies-$r.txt
  done
done
NCU=$(command -v ncu || ls /usr/local/cuda*/bin/ncu 2>/dev/null | head -1)
for b in mpm-old mpm; do for k in step_bodies grid_update_blocks_bodies; do
  timeout 120 $NCU --clock-control none --set full --import-source yes -k regex:"^$k\$" --launch-skip 400 --launch-count 1 -o /tmp/$b-$k $P/$b bench --scene $B/bench-boxes-bodies.toml --steps 500 --warmup 10 > $L/ncu-$b-$k.log 2>&1
  $NCU -i /tmp/$b-$k.ncu-rep --page details --csv > $L/ncu-$b-$k-details.csv 2>&1
  $NCU -i /tmp/$b-$k.ncu-rep --page source --csv --print-source sass > /tmp/$b-$k-sass.csv 2>&1
  python3 scripts/ncu-stalls.py /tmp/$b-$k-sass.csv > $L/ncu-$b-$k-stalls.txt 2>&1
  $NCU -i /tmp/$b-$k.ncu-rep --page source --csv --print-source cuda > $L/ncu-$b-$k-cuda.csv 2>&1
  echo "$b $k: $(grep -m1 '"Duration"' $L/ncu-$b-$k-details.csv | awk -F'","' '{print $(NF-1), $NF}')"
done; done
STEPS=1000 WARMUP=100 RUNS=2 OUT=$L/ab timeout 150 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene dam-break" "--scene bench-655k" > $L/ab.txt 2>&1; tail -4 $L/ab.txt
timeout 280 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 270 > $L/suite.txt 2>&1
tail -3 $L/suite.txt; grep -h "RESULT [0-9]* cells\|panicked" $L/tests/*.log | head -6
tar -czf $OUT/logs.tgz -C $L . && rm -rf $L
