#!/usr/bin/env bash
# The working tree's one_pass_fixed (contributions rounded as written, no branch per contribution):
# fixed-point runs twice (byte-identical run to run?), against 5a21a4c's kernels (how far apart), the
# whole suite.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu S=$PWD/.gpu/scripts
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s72
(cd /tmp; for sc in dam-break fountain; do
  for r in 1 2; do timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export n$r-$sc > /dev/null 2>&1 || echo "new $sc $r failed"; done
  diff -rq n1-$sc n2-$sc > /dev/null && echo "$sc fixed point: $(ls n1-$sc | wc -l) PLY files byte-identical run to run" || echo "$sc DIFFER run to run: $(diff -rq n1-$sc n2-$sc | wc -l)"
  MPM_PTX_DIR=$G/ptx-5a2 timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export h-$sc > /dev/null 2>&1 || echo "5a2 $sc failed"
  echo "$sc, 5a21a4c's kernels against the new:"; python3 $S/plydiff.py h-$sc n1-$sc
done) | tee $OUT/s72/identity.txt
timeout 450 bash .gpu/tests/all > $OUT/s72/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s72/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s72/tests.log | head -20
