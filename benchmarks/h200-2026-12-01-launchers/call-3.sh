#!/usr/bin/env bash
# Call 3 (2 x H200): NCCL's channels for the ghost exchanges. A send/recv pair between two GPUs
# runs on few channels by default (NCCL_MIN_P2P_NCHANNELS=1, per peer 2), each one block of
# threads copying: the 8 MB each way of the 33.5M column's ghost sums took 0.13 ms where NVLink
# carries them in about 0.03. NCCL's P2P settings swept on the weak case and the dam break, one
# process driving both GPUs (--gpus 2), then the best beside the default as two processes.
# Writes table.txt.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
M=$PWD/.gpu/bin/mpm; R=/tmp/runs; mkdir -p $R
bench() { # NAME STEPS "ENV" ARGS...
    local name=$1 steps=$2 vars=$3; shift 3
    if [ $SECONDS -gt 520 ]; then echo "SKIPPED $name (time)" >> $OUT/failures.txt; return; fi
    env $vars timeout 60 $M bench "$@" --steps $steps --warmup 50 --json $R/$name.json > $R/$name.log 2>&1 || { echo "FAILED $name ($vars)"; tail -3 $R/$name.log; } >> $OUT/failures.txt
    echo "$name: $vars" >> $OUT/variants.txt
}
procs() { # NAME STEPS "ENV" ARGS...
    local name=$1 steps=$2 vars=$3; shift 3
    if [ $SECONDS -gt 520 ]; then echo "SKIPPED $name (time)" >> $OUT/failures.txt; return; fi
    for rank in 1 0; do env $vars RANK=$rank WORLD_SIZE=2 LOCAL_RANK=$rank LOCAL_WORLD_SIZE=2 MPM_RUN_ID=$name timeout 60 $M bench "$@" --processes --steps $steps --warmup 50 --json $R/$name.json > $R/$name.$rank.log 2>&1 & done; wait
    echo "$name: $vars (two processes)" >> $OUT/variants.txt
}
W="--particles 33554432 --grid 320"
bench w-default 300 "X=0" $W --gpus 2
bench w-min8 300 "NCCL_MIN_P2P_NCHANNELS=8" $W --gpus 2
bench w-min16 300 "NCCL_MIN_P2P_NCHANNELS=16" $W --gpus 2
bench w-min32 300 "NCCL_MIN_P2P_NCHANNELS=32" $W --gpus 2
bench w-peer8 300 "NCCL_NCHANNELS_PER_PEER=8" $W --gpus 2
bench w-min16-peer16 300 "NCCL_MIN_P2P_NCHANNELS=16 NCCL_NCHANNELS_PER_PEER=16" $W --gpus 2
bench w-chunk2m 300 "NCCL_P2P_NVL_CHUNKSIZE=2097152" $W --gpus 2
bench w-min16-chunk1m 300 "NCCL_MIN_P2P_NCHANNELS=16 NCCL_P2P_NVL_CHUNKSIZE=1048576" $W --gpus 2
bench w-default2 300 "X=0" $W --gpus 2
bench d-default 800 "X=0" --scene dam-break --gpus 2
bench d-min16 800 "NCCL_MIN_P2P_NCHANNELS=16" --scene dam-break --gpus 2
bench d-min16-peer16 800 "NCCL_MIN_P2P_NCHANNELS=16 NCCL_NCHANNELS_PER_PEER=16" --scene dam-break --gpus 2
procs p-default 300 "X=0" $W
procs p-min16 300 "NCCL_MIN_P2P_NCHANNELS=16" $W
bench s-default 200 "X=0" --particles 67108864 --grid 320 --gpus 2
bench s-min16 200 "NCCL_MIN_P2P_NCHANNELS=16" --particles 67108864 --grid 320 --gpus 2
python3 - $R <<'PY' > $OUT/table.txt
import json, glob, os, sys
print("| run | median ms | mean ms | wall ms a substep | sort mean | halo_sum mean | halo_fill mean | g2p mean |")
print("|---|---:|---:|---:|---:|---:|---:|---:|")
for f in sorted(glob.glob(sys.argv[1] + "/*.json"), key=os.path.getmtime):
    for s in json.load(open(f))["phases"]:
        rows = {r["phase"]: r for r in s["rows"]}
        g = lambda p: "%.4f" % rows[p]["mean_ms"] if p in rows else "-"
        print(f"| {os.path.basename(f)[:-5]} | {s['total']['median_ms']:.4f} | {s['total']['mean_ms']:.4f} | {s['wall_ms_per_substep']:.4f} | {g('sort')} | {g('halo_sum')} | {g('halo_fill')} | {g('g2p')} |")
PY
cat $OUT/table.txt $OUT/failures.txt 2>/dev/null; echo "done at $SECONDS s"
