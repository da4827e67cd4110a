#!/usr/bin/env bash
# Call 2 (2 x H200): each process starts from its own share of the spawn (dist::share::Spawn).
# gpu_ranks_on_gpus and gpu_ranks (the ranks' start changed for every launch), then the host's
# peak memory (ru_maxrss of each process) and its time from launch to the end, two processes of the
# 67.1M column, 621dce9 (each process made the whole scene) against this build, and the weak case
# timed by both. Writes tests.txt, memory.txt, table.txt.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
timeout 300 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks_on_gpus,gpu_ranks --out /tmp/tests --timeout 295 > $OUT/tests.txt 2>&1
tail -4 $OUT/tests.txt; cp /tmp/tests/gpu_ranks*.log $OUT/ 2>/dev/null
R=/tmp/runs; mkdir -p $R
# Two processes (torch's variables) of BIN bench ARGS, each under a wrapper that prints its peak RSS.
procs() { # NAME BIN ARGS...
    local name=$1 bin=$2; shift 2
    if [ $SECONDS -gt 540 ]; then echo "SKIPPED $name (time)" >> $OUT/memory.txt; return; fi
    local start=$SECONDS
    for rank in 1 0; do
        RANK=$rank WORLD_SIZE=2 LOCAL_RANK=$rank LOCAL_WORLD_SIZE=2 MPM_RUN_ID=$name timeout 150 python3 -c 'import resource,subprocess,sys; r=subprocess.run(sys.argv[1:]).returncode; print("peak RSS %.2f GB" % (resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1e6), file=sys.stderr); sys.exit(r)' .gpu/bin/$bin bench "$@" --processes --json $R/$name.json > $R/$name.$rank.log 2>&1 &
    done
    wait
    echo "$name: $(grep -h 'peak RSS' $R/$name.0.log) (rank 0), $(grep -h 'peak RSS' $R/$name.1.log) (rank 1), launch to end $((SECONDS - start)) s" >> $OUT/memory.txt
    [ -f $R/$name.json ] || { echo "FAILED $name"; tail -n 5 $R/$name.0.log $R/$name.1.log; } >> $OUT/memory.txt
}
procs strong-67m-before mpm-621dce9 --particles 67108864 --grid 320 --steps 50 --warmup 10
procs strong-67m-now mpm --particles 67108864 --grid 320 --steps 50 --warmup 10
procs weak-33m-before mpm-621dce9 --particles 33554432 --grid 320 --steps 300 --warmup 50
procs weak-33m-now mpm --particles 33554432 --grid 320 --steps 300 --warmup 50
python3 - $R <<'PY' > $OUT/table.txt
import json, glob, os, sys
print("| run | device | median ms | mean ms | wall ms a substep |")
print("|---|---|---:|---:|---:|")
for f in sorted(glob.glob(sys.argv[1] + "/*.json")):
    for s in json.load(open(f))["phases"]:
        print(f"| {os.path.basename(f)[:-5]} | {s['device']} | {s['total']['median_ms']:.4f} | {s['total']['mean_ms']:.4f} | {s['wall_ms_per_substep']:.4f} |")
PY
cat $OUT/memory.txt $OUT/table.txt; echo "done at $SECONDS s"
