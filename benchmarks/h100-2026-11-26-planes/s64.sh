#!/usr/bin/env bash
# The working tree (planes unrolled, grid_update_blocks per scatter at 14 blocks per SM) against d55b8d3:
# substeps, headless frames, fixed-point bytes, ncu of the grid update, the whole suite.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm H=$PWD/.gpu/old/mpm-d55
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s64
cases=("--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene fountain" "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point")
OUT=$OUT/s64/ab RUNS=2 bash scripts/bench-ab.sh $H $M "${cases[@]}" 2>&1 | grep "^| \`" | tee $OUT/s64/ab.txt
OUT=$OUT/s64/ab16 RUNS=1 STEPS=300 WARMUP=100 bash scripts/bench-ab.sh $H $M "--particles 16777216 --grid 256" 2>&1 | grep "^| \`" | tee -a $OUT/s64/ab.txt
(cd /tmp; for sc in dam-break fountain; do
  timeout 90 $H run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export h-$sc > /dev/null 2>&1 || echo "d55 $sc failed"
  timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export n-$sc > /dev/null 2>&1 || echo "new $sc failed"
  diff -rq h-$sc n-$sc > /dev/null && echo "$sc fixed point: $(ls n-$sc | wc -l) PLY files byte-identical, d55b8d3 vs new" || echo "$sc DIFFER: $(diff -rq h-$sc n-$sc | wc -l)"
done) | tee $OUT/s64/identity.txt
for sc in "dam-break --size 960x540" "dam-break-1m --size 960x540"; do for v in old new old new; do B=$M; [ $v = old ] && B=$H
  echo "== $v render $sc"; timeout 90 $B render --scene $sc --frames 90 --no-images 2>&1 | grep -E "frames via"; done; done | tee $OUT/s64/render.txt
timeout 120 ncu --clock-control none --set full -k regex:grid_update_blocks --launch-skip 300 --launch-count 1 -o /tmp/gu $M bench --scene dam-break --steps 400 --warmup 10 > /tmp/ncu.log 2>&1; echo "ncu rc $?"
ncu -i /tmp/gu.ncu-rep --page source --csv --print-source sass > /tmp/gu-sass.csv 2>&1; python3 scripts/ncu-stalls.py /tmp/gu-sass.csv > $OUT/s64/ncu-gu-stalls.txt 2>&1; head -6 $OUT/s64/ncu-gu-stalls.txt
ncu -i /tmp/gu.ncu-rep --page details 2>&1 | grep -E "grid_update_blocks|Duration|Registers Per|Achieved Occ" | head -5
timeout 400 bash .gpu/tests/all > $OUT/s64/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s64/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s64/tests.log | head -20
