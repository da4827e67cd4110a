#!/usr/bin/env bash
# Timing only, wrong near walls: grid_update_blocks without the walls' mirror, compiled out
# (ptx-nomirrorA, 56 registers) or skipped at run time (ptx-nomirrorB, 78), against e59034b: how much
# of the grid update the mirror blocks' longer chains and the registers cost.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s88
for round in 1 2; do
for c in "--scene dam-break" "--scene dam-break-1m" "--scene bench-655k" "--scene dam-break --scatter fixed-point"; do
  for side in head nomirrorA nomirrorB; do
    if [ $side = head ]; then unset MPM_PTX_DIR; else export MPM_PTX_DIR=$G/ptx-$side; fi
    r=$($M bench $c --steps 1000 --warmup 100 2>&1 | grep -E "grid_update_blocks|\*\*total" | awk -F'|' '{printf "%s/%s ", $3, $5}')
    echo "$round | $c | $side | gu median/mean, total median/mean: $r"
  done
done; done | tee $OUT/s88/gu.txt
unset MPM_PTX_DIR
