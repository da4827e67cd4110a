#!/usr/bin/env bash
# Call 3: main 25efdb0 (old) against the build kept (new: call 2's lag1, the stray counts read as
# before), interleaved on one machine; then the GPU tests of the ranks and NCCL, and the suites
# session 29 left unrun (gpu_materials, gpu_solids, gpu_bench). Writes table.txt and tests/.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
timeout 100 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks,gpu_ranks_on_gpus,gpu_nccl,gpu_nccl_pair --out $OUT/tests-a --timeout 90 > $OUT/tests-a.txt 2>&1
tail -6 $OUT/tests-a.txt
mkdir -p $OUT/runs
bench() { # NAME BIN RUN STEPS ARGS...
    local name=$1 bin=$2 run=$3 steps=$4; shift 4
    timeout 120 .gpu/bin/$bin bench "$@" --steps $steps --warmup 50 --json $OUT/runs/$name-$bin-$run.json > $OUT/runs/$name-$bin-$run.log 2>&1 || echo "FAILED $name $bin $run" >> $OUT/failures.txt
}
for run in 1 2; do
  for bin in mpm-old mpm; do
    bench dam-gpus2 $bin $run 800 --scene dam-break --gpus 2
    bench dam-ranks2 $bin $run 800 --scene dam-break --ranks 2
    bench dam-fixed-gpus2 $bin $run 800 --scene dam-break --gpus 2 --scatter fixed-point
  done
done
for bin in mpm-old mpm; do
  bench weak-33m-gpus2 $bin 1 300 --particles 33554432 --grid 320 --gpus 2
  bench strong-67m-gpus2 $bin 1 200 --particles 67108864 --grid 320 --gpus 2
done
bench weak-16m-one mpm 1 300 --particles 16777216 --grid 320
bench strong-67m-one mpm 1 200 --particles 67108864 --grid 320
python3 - $OUT/runs <<'PY' > $OUT/table.txt
import json, glob, os, sys
print("| run | build | round | device | median ms | mean ms | wall ms a substep | sort (migrate + rebin) mean ms | halo_sum mean | halo_fill mean |")
print("|---|---|---|---|---:|---:|---:|---:|---:|---:|")
for f in sorted(glob.glob(sys.argv[1] + "/*.json")):
    name = os.path.basename(f)[:-5]
    case, rnd = name.rsplit("-", 1)
    for b in ("mpm-old", "mpm"):
        if case.endswith("-" + b): case, build = case[: -len(b) - 1], b; break
    for s in json.load(open(f))["phases"]:
        rows = {r["phase"]: r for r in s["rows"]}
        g = lambda p: "%.4f" % rows[p]["mean_ms"] if p in rows else "-"
        print(f"| {case} | {build} | {rnd} | {s['device']} | {s['total']['median_ms']:.4f} | {s['total']['mean_ms']:.4f} | {s['wall_ms_per_substep']:.4f} | {g('sort')} | {g('halo_sum')} | {g('halo_fill')} |")
PY
cat $OUT/table.txt; cat $OUT/failures.txt 2>/dev/null
timeout 300 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_bench,gpu_materials,gpu_solids --out $OUT/tests-b --timeout 280 > $OUT/tests-b.txt 2>&1
tail -6 $OUT/tests-b.txt
