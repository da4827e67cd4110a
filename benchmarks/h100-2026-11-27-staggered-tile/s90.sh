#!/usr/bin/env bash
# grid_update_blocks taking 4 list entries a CUDA block at a time, the interior nodes' sums all loaded
# before any is used (ptx-gu4-NB: held to NB blocks per SM: 10 = 96 registers, 12 = 80, 14 = 72, the
# last two spilling), against e59034b (the binary's own kernels); fixed-point bytes and the kernel
# tests on the 96-register variant.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s90
cases=("--scene dam-break" "--scene bench-655k" "--scene dam-break-1m" "--scene bench-65k" "--scene dam-break --scatter fixed-point" "--scene dam-break --pipeline binned")
(for v in gu4-10 gu4-12 gu4-14; do echo "== e59034b against ptx-$v"; OUT=$OUT/s90/$v RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-$v "${cases[@]}" 2>&1 | grep "^| \`"; done) | tee $OUT/s90/ab.txt
(cd /tmp; for sc in dam-break fountain; do for pl in fused binned; do
  timeout 90 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 60 --export h-$pl-$sc > /dev/null 2>&1 || echo "head $pl $sc failed"
  MPM_PTX_DIR=$G/ptx-gu4-10 timeout 90 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 60 --export g-$pl-$sc > /dev/null 2>&1 || echo "gu4 $pl $sc failed"
  diff -rq h-$pl-$sc g-$pl-$sc > /dev/null && echo "$pl $sc fixed point: $(ls g-$pl-$sc | wc -l) PLY files byte-identical, e59034b vs gu4-10" || echo "$pl $sc DIFFER: $(diff -rq h-$pl-$sc g-$pl-$sc | wc -l)"
done; done) | tee $OUT/s90/identity.txt
(MPM_PTX_DIR=$G/ptx-gu4-10 timeout 240 .gpu/tests/gpu_kernels-* 2>&1 | grep -E "^test result|FAILED|panicked") | tee $OUT/s90/tests.txt
