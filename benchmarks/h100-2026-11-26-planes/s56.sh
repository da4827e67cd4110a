#!/usr/bin/env bash
# one_pass_float's run sums in as many shuffle steps as the warp's longest run needs, GROUP stencil nodes
# at a time: g9 (planes, 5 blocks per SM, 96 registers), g3 (rows), g9b4 (planes, 4 blocks, 128),
# g3b6 (rows, 6 blocks, 80); each against ptx-marks (the warp-listed marks, 5 steps always).
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s56
cases=("--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m")
for v in g9 g3 g9b4 g3b6; do
  echo "== $v"
  OUT=$OUT/s56/$v RUNS=2 bash scripts/bench-ab.sh $M@$G/ptx-marks $M@$G/ptx-$v "${cases[@]}" 2>&1 | tail -7 | grep "^| \`"
  OUT=$OUT/s56/$v-16 RUNS=1 STEPS=300 WARMUP=100 bash scripts/bench-ab.sh $M@$G/ptx-marks $M@$G/ptx-$v "--particles 16777216 --grid 256" 2>&1 | grep "^| \`"
done 2>&1 | tee $OUT/s56/ab.txt
