#!/usr/bin/env bash
# Call 9 (one H200): the working tree after 53517b9: a run in one process reads its particles rank
# by rank on the host (exports, checkpoints), not gathered into every slot on rank 0's GPU. The GPU
# tests of the ranks (every check reads the ranks' particles) and the renderer (which still draws
# the readers' set); `fountain` on 3 ranks to one GPU's PLY bytes; `snowball` checkpointed on 2
# ranks at frame 10 and resumed on one GPU against one GPU's uninterrupted run at frame 20; and the
# export's cost on 2 ranks, 53517b9's binary (`base`) against this one: `mpm run` of the coarse dam
# break exporting every frame.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
M=$PWD/.gpu/bin/mpm; BASE=$PWD/.gpu/bin/mpm-base
timeout 200 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks,gpu_render --out /tmp/tests --timeout 195 > $OUT/tests.txt 2>&1
tail -3 $OUT/tests.txt; cp /tmp/tests/gpu_ranks.log $OUT/ 2>/dev/null
S=/tmp/reads; mkdir -p $S; cd $S
for how in one ranks3; do
  extra=""; [ $how = ranks3 ] && extra="--ranks 3"
  timeout 100 $M run --backend cuda --scatter fixed-point --scene fountain --frames 90 --export f-$how --every 90 $extra > f-$how.log 2>&1
done
cmp -s f-one/frame_000090.ply f-ranks3/frame_000090.ply && echo "fountain on 3 ranks frame 90: one GPU's bytes" >> $OUT/reads.txt || echo "fountain on 3 ranks frame 90: DIFFERS" >> $OUT/reads.txt
timeout 100 $M run --backend cuda --scatter fixed-point --scene snowball --frames 20 --export s-one --every 20 > s-one.log 2>&1
timeout 100 $M run --backend cuda --scatter fixed-point --scene snowball --frames 10 --ranks 2 --checkpoint s-ck > s-ck.log 2>&1
timeout 100 $M run --backend cuda --resume s-ck/checkpoint_000010.mpmck --frames 10 --export s-resumed --every 10 > s-resumed.log 2>&1
cmp -s s-one/frame_000020.ply s-resumed/frame_000020.ply && echo "snowball checkpointed on 2 ranks, resumed on one GPU, frame 20: one GPU's uninterrupted bytes" >> $OUT/reads.txt || echo "snowball checkpointed on 2 ranks, resumed: DIFFERS ($(tail -1 s-resumed.log))" >> $OUT/reads.txt
for round in 1 2; do for bin in base new; do
  B=$M; [ $bin = base ] && B=$BASE
  rm -rf e-$bin; start=$(date +%s.%N)
  timeout 100 $B run --backend cuda --scene dam-break-coarse --frames 60 --ranks 2 --export e-$bin > e-$bin.log 2>&1
  echo "round $round $bin rc $?: $(grep '^time:' e-$bin.log)" >> $OUT/reads.txt
  grep "exported" e-$bin.log >> $OUT/reads.txt
done; done
cat $OUT/reads.txt; echo "done at $SECONDS s"
