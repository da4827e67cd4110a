#!/usr/bin/env bash
# one_pass loading the next particle's position while this one is moved and scattered (ptx-pf),
# and one_pass_fixed's register cap again after the staggered stencil (ptx-f5: 96 registers, ptx-f7:
# 72), each against e59034b (the binary's own kernels).
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s86
fl=("--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene fountain" "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point")
fx=("--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break-1m --scatter fixed-point" "--scene fountain --scatter fixed-point")
(echo "== e59034b against ptx-pf"; OUT=$OUT/s86/pf RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-pf "${fl[@]}" 2>&1 | grep "^| \`"
 OUT=$OUT/s86/pf16 RUNS=1 STEPS=300 WARMUP=100 bash scripts/bench-ab.sh $M $M@$G/ptx-pf "--particles 16777216 --grid 256" 2>&1 | grep "^| \`"
 for v in f5 f7; do echo "== e59034b against ptx-$v"; OUT=$OUT/s86/$v RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-$v "${fx[@]}" 2>&1 | grep "^| \`"; done) | tee $OUT/s86/ab.txt
