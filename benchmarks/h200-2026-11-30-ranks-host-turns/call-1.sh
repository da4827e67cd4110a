#!/usr/bin/env bash
# Call 1: ranks reading their stray counts one substep late, their extremes in stream order, and
# the one-GPU carries ordered by the streams (new) against main 25efdb0 (old), one machine.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0
nvidia-smi -L | tee $OUT/gpus.txt
nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
OLD=.gpu/bin/mpm-old NEW=.gpu/bin/mpm
# Small scenes, where the host's turns show: both ranks' kinds.
OUT=$OUT/ab-small STEPS=800 WARMUP=100 RUNS=2 timeout 150 bash scripts/bench-ab.sh $OLD $NEW \
  "--scene dam-break --gpus 2" "--scene dam-break --ranks 2" "--scene dam-break" > $OUT/ab-small.txt 2>&1
# Weak and strong scaling, one round each side.
OUT=$OUT/ab-large STEPS=300 WARMUP=50 RUNS=1 timeout 320 bash scripts/bench-ab.sh $OLD $NEW \
  "--particles 16777216 --grid 320" "--particles 33554432 --grid 320 --gpus 2" \
  "--particles 67108864 --grid 320 --gpus 2" > $OUT/ab-large.txt 2>&1
python3 - $OUT <<'PY' > $OUT/wall.txt
import json, glob, os, sys
for f in sorted(glob.glob(sys.argv[1] + "/ab-*/case*.json")):
    for s in json.load(open(f))["phases"]:
        print(os.path.relpath(f, sys.argv[1]), s["scene"], s["device"], "median %.4f" % s["total"]["median_ms"], "wall", s.get("wall_ms_per_substep"))
PY
cat $OUT/ab-small.txt $OUT/ab-large.txt $OUT/wall.txt
timeout 100 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks,gpu_ranks_on_gpus,gpu_nccl,gpu_nccl_pair --timeout 90 > $OUT/tests.txt 2>&1
tail -15 $OUT/tests.txt
