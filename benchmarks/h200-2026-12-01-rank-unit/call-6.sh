#!/usr/bin/env bash
# Call 6 (one H200): call 5's change with the frame's end consumed by the one pass that reads it
# (the ranks launch their phases without CudaSolver::step, so call 5's ranks kept it set). The GPU
# tests of the ranks (a new one: sand-column driven frame by frame on 2 ranks and one GPU, the same
# bits every frame) and the lifecycle; plastic solids resumed on one GPU and on 2 ranks by `mpm run`.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
M=$PWD/.gpu/bin/mpm
timeout 200 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_lifecycle,gpu_ranks --out /tmp/tests --timeout 195 > $OUT/tests.txt 2>&1
tail -4 $OUT/tests.txt; cp /tmp/tests/gpu_ranks.log /tmp/tests/gpu_lifecycle.log $OUT/ 2>/dev/null
S=/tmp/resume; mkdir -p $S; cd $S
for scene in sand-column snowball; do
  timeout 100 $M run --backend cuda --scatter fixed-point --scene $scene --frames 20 --export $scene-whole --every 20 --checkpoint $scene-ck --checkpoint-every 10 > $scene-whole.log 2>&1
  timeout 100 $M run --backend cuda --scatter fixed-point --scene $scene --frames 20 --export $scene-whole2 --every 20 --ranks 2 > $scene-whole2.log 2>&1
  cmp -s $scene-whole/frame_000020.ply $scene-whole2/frame_000020.ply && echo "$scene on 2 ranks frame 20: one GPU's bytes" >> $OUT/resume.txt || echo "$scene on 2 ranks frame 20: DIFFERS" >> $OUT/resume.txt
  for how in one ranks2; do
    extra=""; [ $how = ranks2 ] && extra="--ranks 2"
    timeout 100 $M run --backend cuda --resume $scene-ck/checkpoint_000010.mpmck --frames 10 --export $scene-$how --every 10 $extra > $scene-$how.log 2>&1
    cmp -s $scene-whole/frame_000020.ply $scene-$how/frame_000020.ply && echo "$scene resumed $how frame 20: the uninterrupted run's bytes" >> $OUT/resume.txt || echo "$scene resumed $how frame 20: DIFFERS" >> $OUT/resume.txt
  done
done
cat $OUT/resume.txt; echo "done at $SECONDS s"
