#!/usr/bin/env bash
# 8e13650's kernels with the end-of-kernel mass-balance reduction (a barrier) only in CUDA blocks
# that had a chunk able to wrap (ptx-v6): substeps against 8e13650 (the binary's own kernels) and
# against the timing-only variant without returns (ptx-noret); the kernel tests and fixed-point bytes
# on v6's kernels.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s82
cases=("--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break --pipeline binned --scatter fixed-point")
(echo "== 8e13650 against ptx-v6"; OUT=$OUT/s82/v6 RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-v6 "${cases[@]}" 2>&1 | grep "^| \`"
 echo "== ptx-v6 against ptx-noret (timing only)"; OUT=$OUT/s82/noret RUNS=2 bash scripts/bench-ab.sh $M@$G/ptx-v6 $M@$G/ptx-noret "${cases[0]}" "${cases[1]}" 2>&1 | grep "^| \`") | tee $OUT/s82/ab.txt
(cd /tmp; for sc in dam-break fountain; do for pl in fused binned; do
  MPM_PTX_DIR=$G/ptx-v6 timeout 90 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 60 --export n-$pl-$sc > /dev/null 2>&1 || echo "v6 $pl $sc failed"
  MPM_PTX_DIR=$G/ptx-head timeout 90 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 60 --export h-$pl-$sc > /dev/null 2>&1 || echo "head $pl $sc failed"
  diff -rq h-$pl-$sc n-$pl-$sc > /dev/null && echo "$pl $sc fixed point: $(ls n-$pl-$sc | wc -l) PLY files byte-identical, be487f5's kernels vs v6" || echo "$pl $sc DIFFER: $(diff -rq h-$pl-$sc n-$pl-$sc | wc -l)"
done; done) | tee $OUT/s82/identity.txt
(MPM_PTX_DIR=$G/ptx-v6 timeout 240 .gpu/tests/gpu_kernels-* 2>&1 | grep -E "^test result|FAILED|panicked|on one node") | tee $OUT/s82/tests.txt
