#!/usr/bin/env bash
# Call 11 (2 x H200, lent for the first time this session with 301 s of device time left): bb466d1,
# the session's last code. The two-GPU tests (gpu_ranks_on_gpus: the NCCL transports, in one
# process and as processes, the scatter carried with the cuts, solids on two GPUs, fountain, resumes
# from shares; gpu_nccl_pair), then, in what time is left, weak scaling at 16.8M particles a GPU.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
M=$PWD/.gpu/bin/mpm
timeout 170 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks_on_gpus,gpu_nccl_pair --out /tmp/tests --timeout 165 > $OUT/tests.txt 2>&1
tail -4 $OUT/tests.txt; cp /tmp/tests/*.log $OUT/ 2>/dev/null
echo "tests done at $SECONDS s" > $OUT/scaling.txt
cd /tmp
for gpus in 1 2; do
  [ $SECONDS -gt 215 ] && { echo "SKIPPED $gpus GPUs (time)" >> $OUT/scaling.txt; continue; }
  extra=""; [ $gpus = 2 ] && extra="--gpus 2"
  n=$((16777216 * gpus))
  timeout 40 $M bench --particles $n --grid 320 --steps 150 --warmup 30 $extra --json w$gpus.json > w$gpus.log 2>&1
  echo "$gpus GPUs rc $?" >> $OUT/scaling.txt
  python3 -c "import json; s=json.load(open('w$gpus.json'))['phases'][0]; print('$gpus GPUs', s['device'], 'median', round(s['total']['median_ms'],4), 'wall', round(s['wall_ms_per_substep'],4))" >> $OUT/scaling.txt 2>&1
done
cat $OUT/scaling.txt; echo "done at $SECONDS s"
