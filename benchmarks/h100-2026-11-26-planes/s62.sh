#!/usr/bin/env bash
# one_pass_float_planes: its 3 planes unrolled (ptx-unroll), or at 3 blocks per SM (ptx-b3), against e4e64fe's kernels (embedded).
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s62
cases=("--scene dam-break" "--scene bench-655k" "--scene dam-break-1m")
for v in unroll b3; do echo "== $v"
OUT=$OUT/s62/$v RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-$v "${cases[@]}" 2>&1 | grep "^| \`"
OUT=$OUT/s62/$v-16 RUNS=1 STEPS=300 WARMUP=100 bash scripts/bench-ab.sh $M $M@$G/ptx-$v "--particles 16777216 --grid 256" 2>&1 | grep "^| \`"
done | tee $OUT/s62/ab.txt
