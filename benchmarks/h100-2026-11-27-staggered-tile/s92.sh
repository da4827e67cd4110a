#!/usr/bin/env bash
# s91 again with the first clear only in CUDA blocks that have a chunk (ptx-fc2: the tiled
# scatters' flush zeroing each tile node and mark as it reads them), against e59034b (the binary's
# own kernels); fixed-point bytes, memcheck and racecheck, and the whole suite on ptx-fc2.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s92
cases=("--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break-1m --scatter fixed-point" "--scene fountain --scatter fixed-point" "--scene dam-break --pipeline binned --scatter fixed-point" "--scene dam-break --pipeline binned" "--scene dam-break")
(echo "== e59034b against ptx-fc2"; OUT=$OUT/s92/ab RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-fc2 "${cases[@]}" 2>&1 | grep "^| \`") | tee $OUT/s92/ab.txt
(cd /tmp; for sc in dam-break fountain; do for pl in fused binned; do
  timeout 90 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 60 --export h-$pl-$sc > /dev/null 2>&1 || echo "head $pl $sc failed"
  MPM_PTX_DIR=$G/ptx-fc2 timeout 90 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 60 --export f2-$pl-$sc > /dev/null 2>&1 || echo "fc $pl $sc failed"
  diff -rq h-$pl-$sc f2-$pl-$sc > /dev/null && echo "$pl $sc fixed point: $(ls f2-$pl-$sc | wc -l) PLY files byte-identical, e59034b vs fc2" || echo "$pl $sc DIFFER: $(diff -rq h-$pl-$sc f2-$pl-$sc | wc -l)"
done; done) | tee $OUT/s92/identity.txt
(cd /tmp; export MPM_PTX_DIR=$G/ptx-fc2
 for pl in fused binned; do timeout 120 compute-sanitizer --tool memcheck --error-exitcode 9 $M run --backend cuda --scene dam-break --pipeline $pl --scatter fixed-point --frames 2 > /tmp/san.log 2>&1; echo "memcheck $pl fixed dam break: rc=$? $(grep -E 'ERROR SUMMARY' /tmp/san.log)"; done
 timeout 150 compute-sanitizer --tool racecheck --error-exitcode 9 $M run --backend cuda --scene dam-break --pipeline fused --scatter fixed-point --frames 2 > /tmp/san.log 2>&1; echo "racecheck fused fixed dam break: rc=$? $(grep -E 'RACECHECK SUMMARY' /tmp/san.log)"
 timeout 150 compute-sanitizer --tool racecheck --error-exitcode 9 $M run --backend cuda --scene fountain --pipeline binned --scatter fixed-point --frames 2 > /tmp/san.log 2>&1; echo "racecheck binned fixed fountain: rc=$? $(grep -E 'RACECHECK SUMMARY' /tmp/san.log)"
 timeout 150 compute-sanitizer --tool racecheck --error-exitcode 9 $M run --backend cuda --scene fountain --pipeline binned --frames 2 > /tmp/san.log 2>&1; echo "racecheck binned float fountain: rc=$? $(grep -E 'RACECHECK SUMMARY' /tmp/san.log)") | tee $OUT/s92/sanitize.txt
bash .gpu/run true; MPM_PTX_DIR=$G/ptx-fc2 timeout 330 bash .gpu/tests/all > $OUT/s92/tests.log 2>&1; echo "tests rc $?"
(grep -E "^test result" $OUT/s92/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s92/tests.log | head -20) | tee $OUT/s92/tests-summary.txt
