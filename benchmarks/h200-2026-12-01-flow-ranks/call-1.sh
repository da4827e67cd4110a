#!/usr/bin/env bash
# Call 1 (one H200): emitters and sinks on the CUDA ranks. The GPU tests of the ranks on one GPU (a
# new one: `fountain` on 2 ranks, one GPU's bytes, resumed on 3), the lifecycle on one GPU and the
# kernels (emit_particles and gather_into_bin_order changed for every run); `fountain` by hand to
# frame 90 on one GPU and on 2 and 3 ranks (bytes and counts); and the water-only speed before
# (621dce9, session 32's binary, stripped) and after, alternated in this one call.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
M=$PWD/.gpu/bin/mpm; BASE=$PWD/.gpu/bin/mpm-base
timeout 330 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks,gpu_lifecycle,gpu_kernels --out /tmp/tests --timeout 325 > $OUT/tests.txt 2>&1
tail -6 $OUT/tests.txt; cp /tmp/tests/gpu_ranks*.log $OUT/ 2>/dev/null
echo "tests done at $SECONDS s" > $OUT/fountain.txt
F=/tmp/fountain; mkdir -p $F; cd $F
for how in one ranks2 ranks3; do
  extra=""; [ $how = ranks2 ] && extra="--ranks 2"; [ $how = ranks3 ] && extra="--ranks 3"
  start=$SECONDS
  timeout 100 $M run --backend cuda --scatter fixed-point --scene fountain --frames 90 --export $how --every 30 $extra > $how.log 2>&1
  echo "$how rc $? in $((SECONDS - start)) s: $(grep -c '^frame' $how.log) frame lines" >> $OUT/fountain.txt
  grep '^frame' $how.log | tail -1 >> $OUT/fountain.txt
done
for how in ranks2 ranks3; do for f in 30 60 90; do
  cmp -s one/frame_0000$f.ply $how/frame_0000$f.ply && echo "$how frame $f: one GPU's bytes" >> $OUT/fountain.txt || echo "$how frame $f: DIFFERS" >> $OUT/fountain.txt
done; done
head -3 ranks2.log >> $OUT/fountain.txt; cd - > /dev/null
echo "fountain done at $SECONDS s" >> $OUT/fountain.txt
R=/tmp/runs; mkdir -p $R
for round in 1 2; do for bin in base new; do
  B=$M; [ $bin = base ] && B=$BASE
  [ $SECONDS -gt 560 ] && { echo "SKIPPED round $round $bin (time)" >> $OUT/fountain.txt; continue; }
  timeout 60 $B bench --scene dam-break --steps 2000 --warmup 100 --json $R/dam-$bin-$round.json > $R/dam-$bin-$round.log 2>&1
  timeout 60 $B bench --scene bench-655k --steps 1000 --warmup 100 --json $R/b655-$bin-$round.json > $R/b655-$bin-$round.log 2>&1
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
cat $OUT/table.txt $OUT/fountain.txt; echo "done at $SECONDS s"
