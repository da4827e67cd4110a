#!/usr/bin/env bash
# Call 1 (one H200): 56324be, a rank's solver asked through as_rank.rs, the ranks walking Phase::ALL,
# the Transport trait. The GPU tests of the ranks on one GPU (2, 3 and 4 ranks), the lifecycle, NCCL
# and the renderer; `fountain` on 3 ranks against one GPU (PLY bytes at frame 90); and the dam break
# on one GPU (water only, code unchanged) and on 2 ranks of one GPU (the ranks' host clock), 314f3ce's
# binary (`base`) and this one (`new`) alternated in this one call.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
M=$PWD/.gpu/bin/mpm; BASE=$PWD/.gpu/bin/mpm-base
timeout 240 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks,gpu_lifecycle,gpu_nccl,gpu_render --out /tmp/tests --timeout 235 > $OUT/tests.txt 2>&1
tail -6 $OUT/tests.txt; cp /tmp/tests/gpu_ranks.log $OUT/ 2>/dev/null
echo "tests done at $SECONDS s" > $OUT/fountain.txt
F=/tmp/fountain; mkdir -p $F; cd $F
for how in one ranks3; do
  extra=""; [ $how = ranks3 ] && extra="--ranks 3"
  timeout 100 $M run --backend cuda --scatter fixed-point --scene fountain --frames 90 --export $how --every 90 $extra > $how.log 2>&1
  echo "$how rc $?: $(grep '^frame' $how.log | tail -1)" >> $OUT/fountain.txt
done
cmp -s one/frame_000090.ply ranks3/frame_000090.ply && echo "ranks3 frame 90: one GPU's bytes" >> $OUT/fountain.txt || echo "ranks3 frame 90: DIFFERS" >> $OUT/fountain.txt
cd - > /dev/null
R=/tmp/runs; mkdir -p $R
for round in 1 2; do for bin in base new; do
  B=$M; [ $bin = base ] && B=$BASE
  [ $SECONDS -gt 540 ] && { echo "SKIPPED round $round $bin (time)" >> $OUT/fountain.txt; continue; }
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
cp $R/dam2-new-1.log $OUT/ 2>/dev/null
cat $OUT/table.txt $OUT/fountain.txt; echo "done at $SECONDS s"
