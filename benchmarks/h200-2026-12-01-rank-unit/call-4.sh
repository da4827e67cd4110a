#!/usr/bin/env bash
# Call 4 (one H200): e3f34bc. Does a plastic solid resume from a checkpoint to the uninterrupted
# run's bytes on the GPU (docs/checkpoints.md says fixed point does)? snowball, sand-column and
# jelly-drop (elastic: the control) run 20 frames uninterrupted, checkpointed at frame 10, then
# resumed from it to frame 20; PLY bytes at frame 20 compared. And from one GPU's checkpoint on 2
# ranks.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
M=$PWD/.gpu/bin/mpm; S=/tmp/resume; mkdir -p $S; cd $S
for scene in jelly-drop sand-column snowball; do
  timeout 100 $M run --backend cuda --scatter fixed-point --scene $scene --frames 20 --export $scene-whole --every 20 --checkpoint $scene-ck --checkpoint-every 10 > $scene-whole.log 2>&1
  echo "$scene whole rc $?" >> $OUT/resume.txt
  for how in one ranks2; do
    extra=""; [ $how = ranks2 ] && extra="--ranks 2"
    timeout 100 $M run --backend cuda --resume $scene-ck/checkpoint_000010.mpmck --frames 10 --export $scene-$how --every 10 $extra > $scene-$how.log 2>&1
    echo "$scene resumed $how rc $?: $(ls $scene-$how)" >> $OUT/resume.txt
    cmp -s $scene-whole/frame_000020.ply $scene-$how/frame_000020.ply && echo "$scene resumed $how frame 20: the uninterrupted run's bytes" >> $OUT/resume.txt || echo "$scene resumed $how frame 20: DIFFERS" >> $OUT/resume.txt
  done
done
cat $OUT/resume.txt; echo "done at $SECONDS s"
