#!/usr/bin/env bash
# s108: checks of 0d24fd3: the whole suite; fixed-point bytes run to run (fused and binned);
# compute-sanitizer memcheck and racecheck of the changed particle passes (each one_pass entry point).
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
S=$OUT/summary.txt
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $S
(cd /tmp; for r in 1 2; do for sc in dam-break fountain; do for pl in fused binned; do
  timeout 60 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 40 --export f$r-$pl-$sc > /dev/null 2>&1 || echo "$pl $sc $r failed"; done; done; done
 for sc in dam-break fountain; do for pl in fused binned; do diff -rq f1-$pl-$sc f2-$pl-$sc > /dev/null && echo "$pl $sc fixed point: $(ls f2-$pl-$sc | wc -l) PLY files byte-identical run to run" || echo "$pl $sc DIFFERS run to run"; done; done) | tee -a $S
(cd /tmp
 for a in "--scene dam-break" "--scene dam-break --scatter fixed-point" "--scene fountain"; do
   timeout 150 compute-sanitizer --tool memcheck --error-exitcode 9 $M run --backend cuda $a --frames 2 > /tmp/san.log 2>&1; echo "memcheck $a: rc=$? $(grep -E 'ERROR SUMMARY' /tmp/san.log)"
   timeout 150 compute-sanitizer --tool racecheck --error-exitcode 9 $M run --backend cuda $a --frames 2 > /tmp/san.log 2>&1; echo "racecheck $a: rc=$? $(grep -E 'RACECHECK SUMMARY' /tmp/san.log)"
 done) | tee -a $S
timeout 330 bash .gpu/tests/all > $OUT/tests.log 2>&1; echo "tests rc $?" >> $S
(grep -E "^test result" $OUT/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
 grep -E "FAILED|panicked|^not run|not run:" $OUT/tests.log | head -20) >> $S
cat $S
