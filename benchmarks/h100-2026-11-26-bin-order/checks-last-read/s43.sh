#!/usr/bin/env bash
# After the last read (HEAD): the whole suite, fixed-point PLY bytes against 06f9cc2, a run too large for the GPU.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm H=$PWD/.gpu/bin/mpm-head
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s43
(cd /tmp; for sc in dam-break fountain; do
  timeout 90 $H run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export h-$sc > /dev/null 2>&1 || echo "head $sc failed"
  timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export n-$sc > /dev/null 2>&1 || echo "new $sc failed"
  diff -rq h-$sc n-$sc > /dev/null && echo "$sc fixed point: $(ls n-$sc | wc -l) PLY files byte-identical, 06f9cc2 vs HEAD" || echo "$sc DIFFER: $(diff -rq h-$sc n-$sc | wc -l)"
done) | tee $OUT/s43/identity.txt
timeout 330 bash .gpu/run .gpu/tests/all > $OUT/s43/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s43/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s43/tests.log | head -20
