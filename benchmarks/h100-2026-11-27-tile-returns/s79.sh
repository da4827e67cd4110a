#!/usr/bin/env bash
# The fixed-point tile without the atomics' returns, checked only in chunks that could wrap (working tree), against be487f5's kernels
# (ptx-head): substeps; fixed-point bytes (the same integers, so byte-identical expected, fused and
# binned); the kernel tests with the new one; memcheck and racecheck of the three changed kernels.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu S=$PWD/.gpu/scripts
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s79
cases=("--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break-1m --scatter fixed-point" "--scene fountain --scatter fixed-point" "--scene dam-break --pipeline binned --scatter fixed-point" "--scene bench-655k --pipeline binned --scatter fixed-point" "--scene bench-655k" "--particles 16777216 --grid 256 --scatter fixed-point")
OUT=$OUT/s79/ab RUNS=2 bash scripts/bench-ab.sh $M@$G/ptx-head $M "${cases[@]}" 2>&1 | grep "^| " | tee $OUT/s79/ab.txt
(cd /tmp; for sc in dam-break fountain; do
  for pl in fused binned; do
    timeout 90 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 60 --export n-$pl-$sc > /dev/null 2>&1 || echo "new $pl $sc failed"
    MPM_PTX_DIR=$G/ptx-head timeout 90 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 60 --export h-$pl-$sc > /dev/null 2>&1 || echo "head $pl $sc failed"
    diff -rq h-$pl-$sc n-$pl-$sc > /dev/null && echo "$pl $sc fixed point: $(ls n-$pl-$sc | wc -l) PLY files byte-identical, be487f5's kernels vs new" || { echo "$pl $sc DIFFER: $(diff -rq h-$pl-$sc n-$pl-$sc | wc -l)"; python3 $S/plydiff.py h-$pl-$sc n-$pl-$sc; }
  done
done) | tee $OUT/s79/identity.txt
(timeout 240 .gpu/tests/gpu_kernels-* 2>&1 | grep -E "^test result|FAILED|panicked|on one node|fixed_point|not run") | tee $OUT/s79/tests.txt
(cd /tmp; for pl in fused binned; do for tool in memcheck racecheck; do timeout 120 compute-sanitizer --tool $tool --error-exitcode 9 $M run --backend cuda --scene dam-break --pipeline $pl --scatter fixed-point --frames 2 > /tmp/san.log 2>&1; rc=$?; echo "$tool $pl fixed: rc=$rc $(grep -E "ERROR SUMMARY|RACECHECK SUMMARY" /tmp/san.log)"; [ $rc = 0 ] || tail -5 /tmp/san.log; done; done) | tee $OUT/s79/sanitize.txt
