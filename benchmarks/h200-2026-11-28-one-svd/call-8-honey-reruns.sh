#!/usr/bin/env bash
# Device call 8: the honey rope's coiling check, three runs with this change's kernels and two with
# the kernels before it (MPM_PTX_DIR): is its failure in call 7 the change's or the float scatter's?
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p8; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
L=$OUT/logs; mkdir -p $L
for run in new1 old1 new2 old2 new3; do
  case $run in old*) export MPM_PTX_DIR=$P/ptx-before;; *) unset MPM_PTX_DIR;; esac
  timeout 90 $P/gpu_materials the_honey_preset_s_rope_coils --nocapture > $L/$run.log 2>&1
  echo "$run: $(grep -E "rope's foot|test result" $L/$run.log | tr '\n' ' ')"
done
