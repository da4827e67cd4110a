#!/usr/bin/env bash
# Call 3 (one H200): call 2 again after the scatter follows the cuts (carry_old_scatter) instead of
# being scattered again when they move: plastic solids' stress is the pass's own. The GPU tests of
# the ranks (water, a jelly, snow and sand on 2, 3 and 4 ranks to one GPU's bits) and the lifecycle;
# the solid presets on 2 and 3 ranks against one GPU by `mpm run` (PLY bytes); and the dam
# break on one GPU (water only) and on 2 ranks, 314f3ce's binary (`base`) and this one alternated.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
M=$PWD/.gpu/bin/mpm; BASE=$PWD/.gpu/bin/mpm-base
timeout 300 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks,gpu_lifecycle --out /tmp/tests --timeout 295 > $OUT/tests.txt 2>&1
tail -6 $OUT/tests.txt; cp /tmp/tests/gpu_ranks.log $OUT/ 2>/dev/null
echo "tests done at $SECONDS s" > $OUT/solids.txt
S=/tmp/solids; mkdir -p $S; cd $S
for scene in jelly-drop snowball sand-column; do
  for how in one ranks2 ranks3; do
    extra=""; [ $how = ranks2 ] && extra="--ranks 2"; [ $how = ranks3 ] && extra="--ranks 3"
    timeout 100 $M run --backend cuda --scatter fixed-point --scene $scene --frames 20 --export $scene-$how --every 20 $extra > $scene-$how.log 2>&1
    echo "$scene $how rc $?: $(grep '^frame' $scene-$how.log | tail -1)" >> $OUT/solids.txt
    [ $how = one ] || { cmp -s $scene-one/frame_000020.ply $scene-$how/frame_000020.ply && echo "$scene $how frame 20: one GPU's bytes" >> $OUT/solids.txt || echo "$scene $how frame 20: DIFFERS" >> $OUT/solids.txt; }
  done
  tail -2 $scene-ranks2.log >> $OUT/solids.txt
done
cd - > /dev/null
echo "solids done at $SECONDS s" >> $OUT/solids.txt
R=/tmp/runs; mkdir -p $R
for round in 1 2; do for bin in base new; do
  B=$M; [ $bin = base ] && B=$BASE
  [ $SECONDS -gt 540 ] && { echo "SKIPPED round $round $bin (time)" >> $OUT/solids.txt; continue; }
  timeout 60 $B bench --scene dam-break --steps 2000 --warmup 100 --json $R/dam-$bin-$round.json > $R/dam-$bin-$round.log 2>&1
  timeout 60 $B bench --scene dam-break --ranks 2 --steps 800 --warmup 50 --json $R/dam2-$bin-$round.json > $R/dam2-$bin-$round.log 2>&1
done; done
python3 - $R <<'PY' > $OUT/table.txt
import json, glob, os, sys
print("| run | binary | round | device | median ms | mean ms | wall ms a substep |")
print("|---|---|---|---|---:|---:|---:|")
for f in sorted(glob.glob(sys.argv[1] + "/*.json")):
    case, binary, rnd = os.path.basename(f)[:-5].split("-")
    for s in json.load(open(f))["phases"]:
        print(f"| {case} | {binary} | {rnd} | {s['device']} | {s['total']['median_ms']:.4f} | {s['total']['mean_ms']:.4f} | {s['wall_ms_per_substep']:.4f} |")
PY
cat $OUT/table.txt $OUT/solids.txt; echo "done at $SECONDS s"
