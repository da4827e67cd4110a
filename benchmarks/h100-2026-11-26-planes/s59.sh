#!/usr/bin/env bash
# At d55b8d3: the whole suite; ncu of one_pass_float_planes at the dam break.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s59
timeout 120 ncu --clock-control none --set full --import-source yes -k regex:one_pass --launch-skip 30 --launch-count 1 -o /tmp/op $M bench --scene dam-break --steps 40 --warmup 10 > /tmp/ncu.log 2>&1; echo "ncu rc $?"
ncu -i /tmp/op.ncu-rep --page source --csv --print-source sass > /tmp/op-sass.csv 2>&1; python3 scripts/ncu-stalls.py /tmp/op-sass.csv > $OUT/s59/ncu-one_pass-stalls.txt 2>&1; head -24 $OUT/s59/ncu-one_pass-stalls.txt
ncu -i /tmp/op.ncu-rep --page details > $OUT/s59/ncu-details.txt 2>&1; grep -E "one_pass|Duration|Achieved Occupancy|Registers Per" $OUT/s59/ncu-details.txt | head
timeout 470 bash .gpu/tests/all > $OUT/s59/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s59/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run|runs against planes|Runs: max|Planes: max" $OUT/s59/tests.log | head -20
