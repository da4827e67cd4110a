#!/usr/bin/env bash
# Call 3: where the two-GPU substep's time goes, each rank's view: the phases timed on rank 0's
# stream and on rank 1's (MPM_TIMED_RANK), with the committed balance (cuts move where the busiest
# rank holds 10 % over the mean; mpm) and a tighter one (2 %; mpm-tol2). Writes table.txt.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
R=/tmp/runs; mkdir -p $R
bench() { # NAME BIN TIMED STEPS ARGS...
    local name=$1 bin=$2 timed=$3 steps=$4; shift 4
    if [ $SECONDS -gt 420 ]; then echo "SKIPPED $name $bin $timed (time)" >> $OUT/failures.txt; return; fi
    MPM_TIMED_RANK=$timed timeout 150 .gpu/bin/$bin bench "$@" --steps $steps --warmup 50 --json $R/$name-$bin-r$timed.json > $R/$name-$bin-r$timed.log 2>&1 || { echo "FAILED $name $bin $timed"; tail -5 $R/$name-$bin-r$timed.log; } >> $OUT/failures.txt
}
for bin in mpm mpm-tol2; do
  for timed in 0 1; do
    bench weak-33m-gpus2 $bin $timed 300 --particles 33554432 --grid 320 --gpus 2
  done
  bench strong-67m-gpus2 $bin 0 200 --particles 67108864 --grid 320 --gpus 2
done
bench weak-16m-one mpm 0 300 --particles 16777216 --grid 320
python3 - $R <<'PY' > $OUT/table.txt
import json, glob, os, sys
phases = ["sort", "p2g_init", "halo_sum", "grid_update", "halo_fill", "g2p"]
print("| run | build | timed on rank | median ms | mean ms | wall ms a substep | " + " | ".join(p + " median / mean" for p in phases) + " |")
print("|---|---|---|---:|---:|---:|" + "---|" * len(phases))
for f in sorted(glob.glob(sys.argv[1] + "/*.json")):
    name = os.path.basename(f)[:-5]
    case, timed = name.rsplit("-r", 1)
    case, build = (case[:-9], "tol2") if case.endswith("-mpm-tol2") else (case[:-4], "committed")
    for s in json.load(open(f))["phases"]:
        rows = {r["phase"]: r for r in s["rows"]}
        g = lambda p: "%.4f / %.4f" % (rows[p]["median_ms"], rows[p]["mean_ms"]) if p in rows else "-"
        print(f"| {case} | {build} | {timed} | {s['total']['median_ms']:.4f} | {s['total']['mean_ms']:.4f} | {s['wall_ms_per_substep']:.4f} | " + " | ".join(g(p) for p in phases) + " |")
PY
cat $OUT/table.txt; cat $OUT/failures.txt 2>/dev/null
