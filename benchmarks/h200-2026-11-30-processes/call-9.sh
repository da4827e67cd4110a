#!/usr/bin/env bash
# Call 9: NCCL's cuMem buffers off for a process per GPU (dist::launch::prefer_nccl_without_cumem,
# after call 8): gpu_ranks_on_gpus (the process tests run this mpm), then the dam break, weak and
# strong cases in one process (--gpus 2) against two processes, and the one-GPU baselines.
# Writes tests.txt, table.txt.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
timeout 120 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks_on_gpus --out /tmp/tests --timeout 115 > $OUT/tests.txt 2>&1
tail -8 $OUT/tests.txt; cp /tmp/tests/gpu_ranks*.log $OUT/ 2>/dev/null
R=/tmp/runs; mkdir -p $R
bench() { # NAME HOW STEPS ARGS...   HOW: one (one process), before (one process, ab8cde4) or procs (two processes)
    local name=$1 how=$2 steps=$3; shift 3
    if [ $SECONDS -gt 250 ]; then echo "SKIPPED $name $how (time)" >> $OUT/failures.txt; return; fi
    if [ $how != procs ]; then
        local bin=mpm; [ $how = before ] && bin=mpm-ab8cde4
        timeout 60 .gpu/bin/$bin bench "$@" --steps $steps --warmup 50 --json $R/$name-$how.json > $R/$name-$how.log 2>&1 || { echo "FAILED $name $how"; tail -5 $R/$name-$how.log; } >> $OUT/failures.txt
    else
        for rank in 1 0; do
            RANK=$rank WORLD_SIZE=2 LOCAL_RANK=$rank LOCAL_WORLD_SIZE=2 MPM_RUN_ID=$name timeout 60 .gpu/bin/mpm bench "$@" --processes --steps $steps --warmup 50 --json $R/$name-$how.json > $R/$name-$how.$rank.log 2>&1 &
        done
        wait
        [ -f $R/$name-$how.json ] || { echo "FAILED $name $how"; tail -n 5 $R/$name-$how.0.log $R/$name-$how.1.log; } >> $OUT/failures.txt
    fi
}
bench weak-33m one 300 --particles 33554432 --grid 320 --gpus 2
bench weak-33m procs 300 --particles 33554432 --grid 320
bench weak-16m-1gpu one 300 --particles 16777216 --grid 320
bench dam one 800 --scene dam-break --gpus 2
bench dam procs 800 --scene dam-break
bench strong-67m one 200 --particles 67108864 --grid 320 --gpus 2
bench strong-67m procs 200 --particles 67108864 --grid 320
bench strong-67m-1gpu one 200 --particles 67108864 --grid 320
python3 - $R <<'PY' > $OUT/table.txt
import json, glob, os, sys
print("| run | how | device | median ms | mean ms | wall ms a substep | sort mean | halo_sum mean | halo_fill mean | g2p mean |")
print("|---|---|---|---:|---:|---:|---:|---:|---:|---:|")
for f in sorted(glob.glob(sys.argv[1] + "/*.json")):
    case, how = os.path.basename(f)[:-5].rsplit("-", 1)
    for s in json.load(open(f))["phases"]:
        rows = {r["phase"]: r for r in s["rows"]}
        g = lambda p: "%.4f" % rows[p]["mean_ms"] if p in rows else "-"
        print(f"| {case} | {how} | {s['device']} | {s['total']['median_ms']:.4f} | {s['total']['mean_ms']:.4f} | {s['wall_ms_per_substep']:.4f} | {g('sort')} | {g('halo_sum')} | {g('halo_fill')} | {g('g2p')} |")
PY
cat $OUT/table.txt; cat $OUT/failures.txt 2>/dev/null
cp $R/dam-procs.*.log $OUT/ 2>/dev/null
