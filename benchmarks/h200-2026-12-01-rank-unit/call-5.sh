#!/usr/bin/env bash
# Call 5 (one H200): the working tree after e3f34bc: a frame's last substep scatters a plastic
# solid's stress as a resumed run's first scatter does (Solver::ends_frame_next). The GPU tests of
# the lifecycle (a new one: snowball, sand-column and mud-dam-break resumed to the uninterrupted
# run's bits), solids, materials and ranks; call 4's resumes by `mpm run` again; and what it costs:
# e3f34bc's binary (`base`) and this one (`new`) alternated, `mpm bench` on the dam break (water),
# sand-column, snowball and mud-dam-break.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
M=$PWD/.gpu/bin/mpm; BASE=$PWD/.gpu/bin/mpm-base
timeout 330 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_lifecycle,gpu_solids,gpu_materials,gpu_ranks --out /tmp/tests --timeout 325 > $OUT/tests.txt 2>&1
tail -7 $OUT/tests.txt; cp /tmp/tests/gpu_lifecycle.log $OUT/ 2>/dev/null
echo "tests done at $SECONDS s" > $OUT/resume.txt
S=/tmp/resume; mkdir -p $S; cd $S
for scene in sand-column snowball; do
  timeout 100 $M run --backend cuda --scatter fixed-point --scene $scene --frames 20 --export $scene-whole --every 20 --checkpoint $scene-ck --checkpoint-every 10 > $scene-whole.log 2>&1
  for how in one ranks2; do
    extra=""; [ $how = ranks2 ] && extra="--ranks 2"
    timeout 100 $M run --backend cuda --resume $scene-ck/checkpoint_000010.mpmck --frames 10 --export $scene-$how --every 10 $extra > $scene-$how.log 2>&1
    cmp -s $scene-whole/frame_000020.ply $scene-$how/frame_000020.ply && echo "$scene resumed $how frame 20: the uninterrupted run's bytes" >> $OUT/resume.txt || echo "$scene resumed $how frame 20: DIFFERS" >> $OUT/resume.txt
  done
done
cd - > /dev/null
echo "resumes done at $SECONDS s" >> $OUT/resume.txt
R=/tmp/runs; mkdir -p $R
for round in 1 2; do for bin in base new; do
  B=$M; [ $bin = base ] && B=$BASE
  [ $SECONDS -gt 560 ] && { echo "SKIPPED round $round $bin (time)" >> $OUT/resume.txt; continue; }
  timeout 60 $B bench --scene dam-break --steps 2000 --warmup 100 --json $R/dam-$bin-$round.json > /dev/null 2>&1
  timeout 60 $B bench --scene sand-column --steps 800 --warmup 40 --json $R/sand-$bin-$round.json > /dev/null 2>&1
  timeout 60 $B bench --scene snowball --steps 800 --warmup 100 --json $R/snow-$bin-$round.json > /dev/null 2>&1
  timeout 60 $B bench --scene mud-dam-break --steps 800 --warmup 100 --json $R/mud-$bin-$round.json > /dev/null 2>&1
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
cat $OUT/table.txt $OUT/resume.txt; echo "done at $SECONDS s"
