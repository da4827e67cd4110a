#!/usr/bin/env bash
# Session 2026-11-25c, call 1: one_pass variants (skip dead warps, runs of 8, 7 blocks), ncu source profile, suite.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s
for sc in "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break --scatter fixed-point"; do for r in 1 2; do for v in head skip run8 mb7; do
  d=$PWD/.gpu/ptx-$v; [ $v = head ] && d=/nonexistent
  [ $v = run8 ] && [[ "$sc" == *fixed* ]] && continue
  echo "== $v $sc"; MPM_PTX_DIR=$d timeout 60 $M bench $sc --steps 2000 | grep -E "one_pass|total|grid_update_blocks"
done; done; done 2>&1 | tee $OUT/s/bench.txt
timeout 150 ncu --clock-control none --set full --import-source yes -k regex:one_pass --launch-skip 30 --launch-count 1 -o $OUT/s/op-dam $M bench --scene dam-break --steps 40 --warmup 10 > $OUT/s/ncu.log 2>&1; echo "ncu rc $?"
ncu -i $OUT/s/op-dam.ncu-rep --page source --csv --print-source sass > $OUT/s/op-sass.csv 2>&1; echo "src rc $?"; head -c 600 $OUT/s/op-sass.csv
ncu -i $OUT/s/op-dam.ncu-rep --page details --csv > $OUT/s/op-details.csv 2>&1
OUT2=$OUT/s/ab; OUT=$OUT2 RUNS=1 STEPS=300 timeout 60 bash scripts/bench-ab.sh $M $M "--scene bench-65k" > $OUT2.txt 2>&1; echo "ab rc $?"; tail -4 $OUT2.txt
timeout 290 bash .gpu/run .gpu/tests/all > $OUT/s/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s/tests.log | head
