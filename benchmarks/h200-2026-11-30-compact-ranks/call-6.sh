#!/usr/bin/env bash
# Call 6: the ghost sums packed in 32-bit words (new: 20 bytes a node under the float scatter, 36 in
# fixed point) against d7f2c82 (mpm-d7f2c82: 40 bytes a node in 64-bit words), interleaved on one
# machine of two GPUs; the ranks' GPU tests first. Writes tests.txt, table.txt, logs.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
timeout 200 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks,gpu_ranks_on_gpus --out /tmp/tests --timeout 120 > $OUT/tests.txt 2>&1
tail -8 $OUT/tests.txt; cp /tmp/tests/gpu_ranks*.log $OUT/ 2>/dev/null
R=/tmp/runs; mkdir -p $R
bench() { # NAME BIN RUN STEPS ARGS...
    local name=$1 bin=$2 run=$3 steps=$4; shift 4
    if [ $SECONDS -gt 480 ]; then echo "SKIPPED $name $bin $run (time)" >> $OUT/failures.txt; return; fi
    nvidia-smi --query-gpu=index,memory.used --format=csv,noheader,nounits -lms 200 > $R/$name-$bin-$run.mem 2>/dev/null &
    local sampler=$!
    timeout 150 .gpu/bin/$bin bench "$@" --steps $steps --warmup 50 --json $R/$name-$bin-$run.json > $R/$name-$bin-$run.log 2>&1 || { echo "FAILED $name $bin $run"; tail -5 $R/$name-$bin-$run.log; } >> $OUT/failures.txt
    kill $sampler 2>/dev/null; wait $sampler 2>/dev/null
}
for run in 1 2; do
  for bin in mpm-d7f2c82 mpm; do
    bench dam-gpus2 $bin $run 800 --scene dam-break --gpus 2
    bench dam-ranks2 $bin $run 800 --scene dam-break --ranks 2
    bench dam-gpus2-fixed $bin $run 800 --scene dam-break --gpus 2 --scatter fixed-point
  done
done
for bin in mpm-d7f2c82 mpm; do
  bench weak-33m-gpus2 $bin 1 300 --particles 33554432 --grid 320 --gpus 2
  bench strong-67m-gpus2 $bin 1 200 --particles 67108864 --grid 320 --gpus 2
done
bench weak-16m-one mpm 1 300 --particles 16777216 --grid 320
bench strong-67m-one mpm 1 200 --particles 67108864 --grid 320
python3 - $R <<'PY' > $OUT/table.txt
import json, glob, os, sys
print("| run | build | round | device | median ms | mean ms | wall ms a substep | sort (migrate + rebin) mean ms | halo_sum mean | halo_fill mean | g2p mean | peak MiB per GPU |")
print("|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---|")
for f in sorted(glob.glob(sys.argv[1] + "/*.json")):
    name = os.path.basename(f)[:-5]
    case, rnd = name.rsplit("-", 1)
    case, build = (case[:-12], "d7f2c82") if case.endswith("-mpm-d7f2c82") else (case[:-4], "new")
    peak = {}
    for line in open(f[:-5] + ".mem"):
        try:
            i, m = [int(v) for v in line.split(",")]
            peak[i] = max(peak.get(i, 0), m)
        except ValueError:
            pass
    for s in json.load(open(f))["phases"]:
        rows = {r["phase"]: r for r in s["rows"]}
        g = lambda p: "%.4f" % rows[p]["mean_ms"] if p in rows else "-"
        print(f"| {case} | {build} | {rnd} | {s['device']} | {s['total']['median_ms']:.4f} | {s['total']['mean_ms']:.4f} | {s['wall_ms_per_substep']:.4f} | {g('sort')} | {g('halo_sum')} | {g('halo_fill')} | {g('g2p')} | {' / '.join(str(peak[i]) for i in sorted(peak))} |")
PY
cat $OUT/table.txt; cat $OUT/failures.txt 2>/dev/null
grep -h "ranks:" /tmp/tests/*.log 2>/dev/null | head -20
