#!/usr/bin/env bash
# Profiles at e59034b: one_pass_float_planes and one_pass_fixed at the dam break, grid_update_blocks
# at dam-break-1m (ncu --set full, one launch each; stall samples by reason and opcode, details).
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s87
prof() { # name kernel-regex skip bench-args...
  local name=$1 k=$2 skip=$3; shift 3
  timeout 200 ncu --clock-control none --set full --import-source yes -k regex:$k --launch-skip $skip --launch-count 1 -o /tmp/$name $M bench "$@" --steps 400 --warmup 10 > /tmp/$name.log 2>&1; echo "ncu $name rc $?"
  ncu -i /tmp/$name.ncu-rep --page source --csv --print-source sass > /tmp/$name-sass.csv 2>&1
  python3 scripts/ncu-stalls.py /tmp/$name-sass.csv > $OUT/s87/$name-stalls.txt 2>&1
  ncu -i /tmp/$name.ncu-rep --page details > $OUT/s87/$name-details.txt 2>&1
}
prof planes one_pass_float_planes 300 --scene dam-break
prof fixed one_pass_fixed 300 --scene dam-break --scatter fixed-point
prof gu1m grid_update_blocks 300 --scene dam-break-1m
for n in planes fixed gu1m; do echo "=== $n"; head -34 $OUT/s87/$n-stalls.txt; grep -E "Duration|Registers Per|Achieved Occ|Executed Ipc A|Issue Slots Busy|Memory Throughput|DRAM Through|L1/TEX Hit|L2 Hit|Grid Size|Waves Per SM|Block Limit" $OUT/s87/$n-details.txt | head -16; done > $OUT/s87/summary.txt
cat $OUT/s87/summary.txt
