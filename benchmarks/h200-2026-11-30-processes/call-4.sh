#!/usr/bin/env bash
# Call 4: where the host's time goes with a process per GPU (MPM_RANKS_HOST_TIMES=1): call 3 measured
# two processes 0.35 to 1.2 ms a substep slower by the host clock than one process driving both GPUs,
# with the same phase totals. The dam break and the 33.5M column, in one process and as two.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_RANKS_HOST_TIMES=1
nvidia-smi -L > $OUT/gpus.txt
R=/tmp/runs; mkdir -p $R
one() { timeout 100 .gpu/bin/mpm bench "$@" --warmup 50 > $R/one.log 2>&1; grep -h "wall\|Wall\|rank .*host" $R/one.log; }
procs() {
  for rank in 1 0; do
    RANK=$rank WORLD_SIZE=2 LOCAL_RANK=$rank LOCAL_WORLD_SIZE=2 MPM_RUN_ID=r$SECONDS timeout 100 .gpu/bin/mpm bench "$@" --processes --warmup 50 > $R/procs.$rank.log 2>&1 &
  done
  wait; grep -h "Wall\|rank .*host\|error" $R/procs.0.log $R/procs.1.log
}
{
echo "## dam break, one process"; one --scene dam-break --gpus 2 --steps 400
echo "## dam break, two processes"; procs --scene dam-break --steps 400
echo "## 33.5M column, one process"; one --particles 33554432 --grid 320 --gpus 2 --steps 150
echo "## 33.5M column, two processes"; procs --particles 33554432 --grid 320 --steps 150
} > $OUT/host-times.txt 2>&1
cat $OUT/host-times.txt
