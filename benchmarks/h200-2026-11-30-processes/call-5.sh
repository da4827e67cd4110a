#!/usr/bin/env bash
# Call 5: the host exchanges between processes by NCCL's all-gather (MPM_TURN_ALLGATHER=1, as in
# calls 2 to 4) against grouped sends and receives, two processes, MPM_RANKS_HOST_TIMES=1; NCCL's
# transports as NCCL_DEBUG=INFO names them.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_RANKS_HOST_TIMES=1
nvidia-smi -L > $OUT/gpus.txt
R=/tmp/runs; mkdir -p $R
procs() { # LABEL ENV ARGS...
  local label=$1 env=$2; shift 2
  echo "## $label"
  for rank in 1 0; do
    env $env RANK=$rank WORLD_SIZE=2 LOCAL_RANK=$rank LOCAL_WORLD_SIZE=2 MPM_RUN_ID=r$SECONDS$label timeout 100 .gpu/bin/mpm bench "$@" --processes --warmup 50 > $R/$label.$rank.log 2>&1 &
  done
  wait; grep -h "Wall\|rank .*host\|error" $R/$label.0.log $R/$label.1.log
}
{
procs dam-allgather MPM_TURN_ALLGATHER=1 --scene dam-break --steps 400
procs dam-sendrecv X=1 --scene dam-break --steps 400
procs col-allgather MPM_TURN_ALLGATHER=1 --particles 33554432 --grid 320 --steps 150
procs col-sendrecv X=1 --particles 33554432 --grid 320 --steps 150
procs dam-debug NCCL_DEBUG=INFO --scene dam-break --steps 100
} > $OUT/host-times.txt 2>&1
grep -h "via\|Channel 00\|NCCL INFO Using\|comm 0x" $R/dam-debug.0.log | head -40 > $OUT/nccl-transports.txt
cat $OUT/host-times.txt; cat $OUT/nccl-transports.txt
