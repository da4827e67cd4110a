#!/usr/bin/env bash
# s104: s103's B refined, against 767bb73's kernels (ptx-a), one binary (mpm, "D", embedded):
#   ptx-f3: B with one_pass_fixed keeping the gather node by node (B's rows cost it 3 % at 80 registers);
#   ptx-f1: B with one_pass_fixed at 5 blocks per SM (96 registers);
#   D: ptx-f3 plus the Tait law's powers by squaring instead of powf (CPU twin the same).
# Then fixed-point bytes run to run on D, and the whole suite on D.
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
export MPM_BIN=$M NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
S=$OUT/summary.txt
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $S
bash .gpu/run true
cases=("--scene dam-break" "--scene bench-655k" "--scene dam-break-1m" "--scene bench-65k" "--scene fountain" "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene dam-break --pipeline binned")
(echo "== A (767bb73) against D"; OUT=/tmp/ad RUNS=2 bash scripts/bench-ab.sh $M@$G/ptx-a $M "${cases[@]}" 2>&1 | grep "^| \`") | tee -a $S
(echo "== 16.8M: A against D"; OUT=/tmp/ad16 RUNS=1 STEPS=300 WARMUP=100 bash scripts/bench-ab.sh $M@$G/ptx-a $M "--particles 16777216 --grid 256" 2>&1 | grep "^| \`") | tee -a $S
(echo "== A against F3 (D without the powers)"; OUT=/tmp/af3 RUNS=1 bash scripts/bench-ab.sh $M@$G/ptx-a $M@$G/ptx-f3 "--scene dam-break" "--scene bench-655k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" 2>&1 | grep "^| \`") | tee -a $S
(echo "== F3 against F1 (fixed at 5 blocks, rows)"; OUT=/tmp/f31 RUNS=1 bash scripts/bench-ab.sh $M@$G/ptx-f3 $M@$G/ptx-f1 "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene dam-break-1m --scatter fixed-point" 2>&1 | grep "^| \`") | tee -a $S
(cd /tmp; for r in 1 2; do for sc in dam-break fountain; do
  timeout 60 $M run --backend cuda --scene $sc --scatter fixed-point --frames 40 --export d$r-$sc > /dev/null 2>&1 || echo "$sc $r failed"; done; done
 for sc in dam-break fountain; do diff -rq d1-$sc d2-$sc > /dev/null && echo "$sc fixed point on D: $(ls d2-$sc | wc -l) PLY files byte-identical run to run" || echo "$sc DIFFERS run to run"; done) >> $S
timeout 320 bash .gpu/tests/all > $OUT/tests.log 2>&1; echo "tests rc $?" >> $S
(grep -E "^test result" $OUT/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
 grep -E "FAILED|panicked|^not run|not run:" $OUT/tests.log | head -20) >> $S
cat $S
