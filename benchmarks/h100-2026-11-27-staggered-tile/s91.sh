#!/usr/bin/env bash
# The tiled scatters' flush zeroing each tile node and mark as it reads them, the tile cleared once
# before the first chunk (ptx-fc: one barrier and one pass fewer a chunk), against e59034b (the
# binary's own kernels); fixed-point bytes, the kernel tests, memcheck and racecheck on ptx-fc.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s91
cases=("--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break-1m --scatter fixed-point" "--scene fountain --scatter fixed-point" "--scene dam-break --pipeline binned --scatter fixed-point" "--scene dam-break --pipeline binned" "--scene dam-break")
(echo "== e59034b against ptx-fc"; OUT=$OUT/s91/ab RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-fc "${cases[@]}" 2>&1 | grep "^| \`") | tee $OUT/s91/ab.txt
(cd /tmp; for sc in dam-break fountain; do for pl in fused binned; do
  timeout 90 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 60 --export h-$pl-$sc > /dev/null 2>&1 || echo "head $pl $sc failed"
  MPM_PTX_DIR=$G/ptx-fc timeout 90 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 60 --export f-$pl-$sc > /dev/null 2>&1 || echo "fc $pl $sc failed"
  diff -rq h-$pl-$sc f-$pl-$sc > /dev/null && echo "$pl $sc fixed point: $(ls f-$pl-$sc | wc -l) PLY files byte-identical, e59034b vs fc" || echo "$pl $sc DIFFER: $(diff -rq h-$pl-$sc f-$pl-$sc | wc -l)"
done; done) | tee $OUT/s91/identity.txt
(cd /tmp; export MPM_PTX_DIR=$G/ptx-fc
 for pl in fused binned; do timeout 120 compute-sanitizer --tool memcheck --error-exitcode 9 $M run --backend cuda --scene dam-break --pipeline $pl --scatter fixed-point --frames 2 > /tmp/san.log 2>&1; echo "memcheck $pl fixed dam break: rc=$? $(grep -E 'ERROR SUMMARY' /tmp/san.log)"; done
 timeout 150 compute-sanitizer --tool racecheck --error-exitcode 9 $M run --backend cuda --scene dam-break --pipeline fused --scatter fixed-point --frames 2 > /tmp/san.log 2>&1; echo "racecheck fused fixed dam break: rc=$? $(grep -E 'RACECHECK SUMMARY' /tmp/san.log)"
 timeout 150 compute-sanitizer --tool racecheck --error-exitcode 9 $M run --backend cuda --scene fountain --pipeline binned --scatter fixed-point --frames 2 > /tmp/san.log 2>&1; echo "racecheck binned fixed fountain: rc=$? $(grep -E 'RACECHECK SUMMARY' /tmp/san.log)"
 timeout 150 compute-sanitizer --tool racecheck --error-exitcode 9 $M run --backend cuda --scene fountain --pipeline binned --frames 2 > /tmp/san.log 2>&1; echo "racecheck binned float fountain: rc=$? $(grep -E 'RACECHECK SUMMARY' /tmp/san.log)") | tee $OUT/s91/sanitize.txt
(MPM_PTX_DIR=$G/ptx-fc timeout 240 .gpu/tests/gpu_kernels-* 2>&1 | grep -E "^test result|FAILED|panicked") | tee $OUT/s91/tests.txt
