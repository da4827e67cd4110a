#!/usr/bin/env bash
# Call 6: the waits on the other processes spin (std::hint::spin_loop) instead of yielding the
# thread: one process against two, MPM_RANKS_HOST_TIMES=1, the dam break and the 33.5M column.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_RANKS_HOST_TIMES=1
nvidia-smi -L > $OUT/gpus.txt
R=/tmp/runs; mkdir -p $R
one() { echo "## $1 one process"; shift; timeout 100 .gpu/bin/mpm bench "$@" --gpus 2 --warmup 50 > $R/one.log 2>&1; grep -h "Wall\|rank .*host" $R/one.log; }
procs() {
  local label=$1; shift; echo "## $label two processes"
  for rank in 1 0; do
    RANK=$rank WORLD_SIZE=2 LOCAL_RANK=$rank LOCAL_WORLD_SIZE=2 MPM_RUN_ID=r$SECONDS$label timeout 100 .gpu/bin/mpm bench "$@" --processes --warmup 50 > $R/$label.$rank.log 2>&1 &
  done
  wait; grep -h "Wall\|rank .*host\|error" $R/$label.0.log $R/$label.1.log
}
{
one dam --scene dam-break --steps 400
procs dam --scene dam-break --steps 400
one col --particles 33554432 --grid 320 --steps 150
procs col --particles 33554432 --grid 320 --steps 150
} > $OUT/host-times.txt 2>&1
cat $OUT/host-times.txt
