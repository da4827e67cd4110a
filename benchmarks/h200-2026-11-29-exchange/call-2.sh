#!/usr/bin/env bash
# Device call 2 (issue 42): call 1's block sums were slower in the bench and are dropped; step_bodies
# now also sweeps the six walls' corners in one pass of (wall, corner) pairs (claim_contact).
# mpm-old is e675757; mpm@ptx-lb10 / @ptx-lb12 hold grid_update_blocks_bodies to 10 / 12 blocks an
# SM (__launch_bounds__). Bench rows, water alone A/B, step_bodies' stalls sampled every 32 cycles,
# both grid updates' registers, gpu_bodies and gpu_lifecycle.
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p2; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_* $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
B=benches/scenes
row() { echo "$1: $(grep -E '^\| mirror_walls' $2 | awk -F'|' '{print "grid", $3}') $(grep -E '^\| \*\*total' $2 | awk -F'|' '{print "total", $3}')"; }
for r in 1 2; do
  for s in boxes-static boxes-bodies; do for b in mpm-old mpm; do
    timeout 60 $P/$b bench --scene $B/bench-$s.toml --steps 1000 > $L/$b-$s-$r.txt 2>&1; row "$b $s $r" $L/$b-$s-$r.txt
  done; done
  for v in lb10 lb12; do
    MPM_PTX_DIR=$P/ptx-$v timeout 60 $P/mpm bench --scene $B/bench-boxes-bodies.toml --steps 1000 > $L/ptx-$v-boxes-bodies-$r.txt 2>&1; row "ptx-$v boxes-bodies $r" $L/ptx-$v-boxes-bodies-$r.txt
  done
done
NCU=$(command -v ncu || ls /usr/local/cuda*/bin/ncu 2>/dev/null | head -1)
timeout 150 $NCU --clock-control none --set full --import-source yes --sampling-interval 0 -k regex:'^step_bodies$' --launch-skip 400 --launch-count 3 -o /tmp/sb $P/mpm bench --scene $B/bench-boxes-bodies.toml --steps 500 --warmup 10 > $L/ncu-step_bodies.log 2>&1
$NCU -i /tmp/sb.ncu-rep --page details --csv > $L/ncu-step_bodies-details.csv 2>&1
$NCU -i /tmp/sb.ncu-rep --page source --csv --print-source sass > $L/ncu-step_bodies-sass.csv 2>&1
python3 scripts/ncu-stalls.py $L/ncu-step_bodies-sass.csv > $L/ncu-step_bodies-stalls.txt 2>&1; head -20 $L/ncu-step_bodies-stalls.txt
$NCU -i /tmp/sb.ncu-rep --page source --csv --print-source cuda > $L/ncu-step_bodies-cuda.csv 2>&1
for s in boxes-static:grid_update_blocks boxes-bodies:grid_update_blocks_bodies; do
  timeout 120 $NCU --clock-control none --section LaunchStats --section Occupancy --section SpeedOfLight -k regex:"^${s#*:}\$" --launch-skip 400 --launch-count 3 $P/mpm bench --scene $B/bench-${s%%:*}.toml --steps 500 --warmup 10 > $L/ncu-${s#*:}.txt 2>&1
  echo "${s#*:}: $(grep -E 'Registers Per Thread|Duration|Achieved Occupancy' $L/ncu-${s#*:}.txt | head -3 | tr -s ' ' | tr '\n' ';')"
done
STEPS=1000 WARMUP=100 RUNS=2 OUT=$L/ab timeout 100 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene dam-break" > $L/ab.txt 2>&1; tail -3 $L/ab.txt
timeout 280 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 270 > $L/suite.txt 2>&1
tail -3 $L/suite.txt; grep -h "RESULT [0-9]* cells\|panicked" $L/tests/*.log | head -6
tar -czf $OUT/logs.tgz -C $L . && rm -rf $L
