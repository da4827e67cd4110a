#!/usr/bin/env bash
# 8e13650's tile with its adds' rounding through F2I.S64, as be487f5 rounded, instead of F2I.S32
# (ptx-v5; the same integers below 2^31): substeps against 8e13650's kernels; fixed-point bytes
# against be487f5's; the whole suite on v5's kernels (MPM_PTX_DIR).
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu S=$PWD/.gpu/scripts
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s81
cases=("--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene dam-break-1m --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break --pipeline binned --scatter fixed-point")
OUT=$OUT/s81/ab RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-v5 "${cases[@]}" 2>&1 | grep "^| " | tee $OUT/s81/ab.txt
(cd /tmp; for sc in dam-break fountain; do for pl in fused binned; do
  MPM_PTX_DIR=$G/ptx-v5 timeout 90 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 60 --export n-$pl-$sc > /dev/null 2>&1 || echo "v5 $pl $sc failed"
  MPM_PTX_DIR=$G/ptx-head timeout 90 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 60 --export h-$pl-$sc > /dev/null 2>&1 || echo "head $pl $sc failed"
  diff -rq h-$pl-$sc n-$pl-$sc > /dev/null && echo "$pl $sc fixed point: $(ls n-$pl-$sc | wc -l) PLY files byte-identical, be487f5's kernels vs v5" || echo "$pl $sc DIFFER: $(diff -rq h-$pl-$sc n-$pl-$sc | wc -l)"
done; done) | tee $OUT/s81/identity.txt
MPM_PTX_DIR=$G/ptx-v5 timeout 400 bash .gpu/tests/all > $OUT/s81/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s81/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run|NOT RUN|skipped" $OUT/s81/tests.log | head -20
