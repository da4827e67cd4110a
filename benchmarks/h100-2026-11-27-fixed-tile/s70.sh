#!/usr/bin/env bash
# one_pass_fixed without a branch per contribution (the working tree) against 5a21a4c's kernels
# (ptx-5a2): substeps, fixed-point bytes, the kernel tests (the new one on both kernels), sanitizers,
# ncu of the new one_pass_fixed at bench-655k.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s70
cases=("--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break-1m --scatter fixed-point" "--scene fountain --scatter fixed-point" "--scene bench-655k")
OUT=$OUT/s70/ab RUNS=2 bash scripts/bench-ab.sh $M@$G/ptx-5a2 $M "${cases[@]}" 2>&1 | grep "^| \`" | tee $OUT/s70/ab.txt
(cd /tmp; for sc in dam-break fountain; do
  MPM_PTX_DIR=$G/ptx-5a2 timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export h-$sc > /dev/null 2>&1 || echo "5a2 $sc failed"
  timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export n-$sc > /dev/null 2>&1 || echo "new $sc failed"
  diff -rq h-$sc n-$sc > /dev/null && echo "$sc fixed point: $(ls n-$sc | wc -l) PLY files byte-identical, 5a21a4c's kernels vs new" || echo "$sc DIFFER: $(diff -rq h-$sc n-$sc | wc -l)"
done) | tee $OUT/s70/identity.txt
(echo "== new kernels"; timeout 150 .gpu/tests/gpu_kernels-* fixed_point_scatter_past --nocapture 2>&1 | grep -E "particles at|tile misses|^test result|panicked"
echo "== 5a21a4c's kernels"; MPM_PTX_DIR=$G/ptx-5a2 timeout 150 .gpu/tests/gpu_kernels-* fixed_point_scatter_past --nocapture 2>&1 | grep -E "particles at|tile misses|^test result|panicked") | tee $OUT/s70/test-new.txt
sc=$PWD/benchmarks/h100-2026-11-25-mirror-in-update/dam-break-crossing.toml
for tool in memcheck racecheck; do timeout 90 compute-sanitizer --tool $tool --error-exitcode 9 $M run --backend cuda --scene $sc --scatter fixed-point --frames 2 > /tmp/san.log 2>&1; echo "$tool crossing fixed: rc=$? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/san.log)"; done | tee $OUT/s70/sanitize.txt
timeout 150 ncu --clock-control none --set full -k regex:one_pass_fixed --launch-skip 300 --launch-count 1 -o /tmp/opf $M bench --scene bench-655k --scatter fixed-point --steps 400 --warmup 10 > /tmp/ncu.log 2>&1; echo "ncu rc $?"
ncu -i /tmp/opf.ncu-rep --page source --csv --print-source sass > /tmp/opf-sass.csv 2>&1; python3 scripts/ncu-stalls.py /tmp/opf-sass.csv > $OUT/s70/ncu-one_pass_fixed-stalls.txt 2>&1; head -22 $OUT/s70/ncu-one_pass_fixed-stalls.txt
ncu -i /tmp/opf.ncu-rep --page details 2>&1 | grep -E "one_pass_fixed|Duration|Registers Per|Achieved Occ|Executed Ipc A|Issue Slots Busy" | head -8 | tee $OUT/s70/ncu-details.txt
timeout 200 bash .gpu/tests/all > /tmp/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" /tmp/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}' | tee $OUT/s70/suite.txt
grep -E "FAILED|panicked|^not run" /tmp/tests.log | head -20 | tee -a $OUT/s70/suite.txt
