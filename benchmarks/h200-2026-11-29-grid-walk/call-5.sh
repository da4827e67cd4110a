#!/usr/bin/env bash
# Session 20 call 5 (issue 47): what the mirror's registers cost. w3: grid_update_blocks with the
# mirror compiled out (wrong near walls: timing only); w4: the same held to 32 registers.
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p22; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
M=$P/mpm; export NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
for w in 3 4; do
  MPM_PTX_DIR=$PWD/.gpu-exp/ptx-w$w timeout 60 ncu --clock-control none -k regex:grid_update_blocks --launch-skip 100 --launch-count 1 --section LaunchStats --section Occupancy --section SpeedOfLight $M bench --scene dam-break --steps 150 --warmup 10 2>&1 | grep -E "Registers Per|Achieved Occ|Theoretical Occ|Duration" | sed "s/^/w$w dam /"
  MPM_PTX_DIR=$PWD/.gpu-exp/ptx-w$w timeout 90 ncu --clock-control none -k regex:grid_update_blocks --launch-skip 30 --launch-count 1 --section LaunchStats --section Occupancy --section SpeedOfLight $M bench --particles 16777216 --grid 256 --steps 40 --warmup 10 2>&1 | grep -E "Registers Per|Achieved Occ|Duration" | sed "s/^/w$w 16m /"
done
for w in 3 4; do
  STEPS=200 WARMUP=50 RUNS=1 OUT=/tmp/ab16-$w bash scripts/bench-ab.sh $M $M@$PWD/.gpu-exp/ptx-w$w "--particles 16777216 --grid 256" > $OUT/ab16-w$w.txt 2>&1
  grep '^| `' $OUT/ab16-w$w.txt
  STEPS=800 WARMUP=100 RUNS=1 OUT=/tmp/ab-$w bash scripts/bench-ab.sh $M $M@$PWD/.gpu-exp/ptx-w$w "--scene dam-break" "--scene bench-65k" "--scene dam-break-1m" > $OUT/ab-w$w.txt 2>&1
  grep '^| `' $OUT/ab-w$w.txt
done
