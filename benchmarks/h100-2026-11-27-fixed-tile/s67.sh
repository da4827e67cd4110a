#!/usr/bin/env bash
# one_pass_fixed with its contributions summed over warp runs by planes in 32-bit tile units (the
# working tree) against 8a2d656's one_pass_fixed (ptx-8a2): substeps, fixed-point bytes, the whole suite.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s67
cases=("--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break-1m --scatter fixed-point" "--scene fountain --scatter fixed-point" "--scene bench-655k")
OUT=$OUT/s67/ab RUNS=2 bash scripts/bench-ab.sh $M@$G/ptx-8a2 $M "${cases[@]}" 2>&1 | grep "^| \`" | tee $OUT/s67/ab.txt
(cd /tmp; for sc in dam-break fountain; do
  MPM_PTX_DIR=$G/ptx-8a2 timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export h-$sc > /dev/null 2>&1 || echo "8a2 $sc failed"
  timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export n-$sc > /dev/null 2>&1 || echo "new $sc failed"
  diff -rq h-$sc n-$sc > /dev/null && echo "$sc fixed point: $(ls n-$sc | wc -l) PLY files byte-identical, 8a2d656's kernels vs new" || echo "$sc DIFFER: $(diff -rq h-$sc n-$sc | wc -l)"
done) | tee $OUT/s67/identity.txt
timeout 400 bash .gpu/tests/all > $OUT/s67/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s67/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s67/tests.log | head -20
sc=$PWD/benchmarks/h100-2026-11-25-mirror-in-update/dam-break-crossing.toml
for tool in memcheck racecheck; do timeout 90 compute-sanitizer --tool $tool --error-exitcode 9 $M run --backend cuda --scene $sc --scatter fixed-point --frames 2 > /tmp/san.log 2>&1; echo "$tool crossing fixed: rc=$? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/san.log)"; done | tee $OUT/s67/sanitize.txt
