#!/usr/bin/env bash
# grid_update_blocks: main's kernel (head) and v1 (a barrier every iteration; 1 or 2 node blocks per
# CUDA block), with at most 32, 8 or 4 CUDA blocks per SM in the launch. One binary, MPM_PTX_DIR.
export NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/cta3
b() { timeout 100 "$@" 2>&1 | grep -E "^\| \*\*total|grid_update_blocks" ; }
for args in "--scene bench-65k" "--scene dam-break" "--scene bench-655k" "--scene dam-break --scatter fixed-point" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $args == *16777216* ]] && steps="300 --warmup 100"
  for rep in 1 2; do for v in head-1-32 head-1-8 head-1-4 v1-1-32 v1-1-8 v1-2-8 v1-2-4; do
  IFS=- read k pc ps <<< "$v"
  echo "== $v $args"; MPM_PTX_DIR=$PWD/.gpu/ptx-$k MPM_GU_PER_CTA=$pc MPM_GU_CTAS_PER_SM=$ps b $M bench $args --steps $steps
done; done; done > $OUT/cta3/bench.txt
grep -E "^== |total" $OUT/cta3/bench.txt | cut -c1-60 | paste - - | awk '{print $2, $3, $4, $8}' | sort -k2,3 -k1,1 -s
tar czf $OUT/cta3.tgz -C $OUT cta3
