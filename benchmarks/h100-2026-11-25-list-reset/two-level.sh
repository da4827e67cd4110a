#!/usr/bin/env bash
# grid_update_blocks empties the node block list itself, its blocks counted in 32 groups (mpm),
# against 0aa7704 (mpm-old, the memset after the launch) and one counter for all blocks
# (mpm-single). Bench, PLY bytes, memcheck, the whole suite.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
B=$PWD/.gpu/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s30
OUT=$OUT/s30/ab bash scripts/bench-ab.sh $B/mpm-old $B/mpm "--scene bench-65k" "--scene dam-break" "--scene bench-655k" "--scene bench-65k --scatter fixed-point" > $OUT/s30/bench.txt 2>&1; tail -7 $OUT/s30/bench.txt
OUT=$OUT/s30/ab16 STEPS=300 WARMUP=100 bash scripts/bench-ab.sh $B/mpm-old $B/mpm "--particles 16777216 --grid 256" > $OUT/s30/bench-16m.txt 2>&1; tail -3 $OUT/s30/bench-16m.txt
OUT=$OUT/s30/ab16s STEPS=300 WARMUP=100 bash scripts/bench-ab.sh $B/mpm-single $B/mpm "--particles 16777216 --grid 256" "--scene bench-65k" > $OUT/s30/bench-single.txt 2>&1; tail -4 $OUT/s30/bench-single.txt
(cd /tmp
for sc in dam-break fountain; do
  timeout 60 $B/mpm-old run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export s30-old-$sc > /dev/null 2>&1 || echo "run old $sc failed"
  timeout 60 $B/mpm run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export s30-new-$sc > /dev/null 2>&1 || echo "run new $sc failed"
  diff -rq s30-old-$sc s30-new-$sc > /dev/null && echo "$sc fixed point: $(ls s30-new-$sc | wc -l) files byte-identical" || echo "$sc DIFFER"; done) | tee $OUT/s30/ply.txt
for sc in "--scene dam-break" "--scene bench-65k --scatter fixed-point"; do
  echo "== memcheck $sc"; timeout 120 compute-sanitizer --tool memcheck --error-exitcode 9 $B/mpm bench $sc --steps 20 --warmup 0 2>&1 | grep -E "ERROR SUMMARY" | head -3
done | tee $OUT/s30/memcheck.txt
timeout 300 bash .gpu/run .gpu/tests/all > $OUT/s30/suite.log 2>&1; echo "suite rc=$?"
grep -E "^test result" $OUT/s30/suite.log | awk '{p+=$4; f+=$6} END {print p" passed, "f" failed"}'
grep -E "FAILED|panicked|not run" $OUT/s30/suite.log | head
