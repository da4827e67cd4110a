#!/usr/bin/env bash
# Issue 18's table: 3a153e5 (the issue's start) against d55b8d3, one machine, interleaved.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm O=$PWD/.gpu/old/mpm-3a153e5
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s60
for c in "--scene bench-655k" "--scene bench-65k" "--scene dam-break" "--scene bench-655k --scatter fixed-point" "--scene dam-break-1m" "--particles 16777216 --grid 256 --steps 300 --warmup 100"; do
  for v in old new old new; do B=$M; [ $v = old ] && B=$O
    case "$c" in *1m*) [ $v = old ] && continue;; esac
    st="--steps 2000 --warmup 200"; case "$c" in *steps*) st="";; esac
    echo "$v $c: $(timeout 120 $B bench $c $st 2>&1 | grep -E '\*\*total' | head -1)"
  done; done | tee $OUT/s60/bench.txt
for sc in "dam-break --size 960x540" "dam-break --size 1920x1080" "dam-break-1m --size 960x540"; do for v in old new old new; do B=$M; [ $v = old ] && B=$O
  case "$sc" in *1m*) [ $v = old ] && continue;; esac
  echo "== $v render $sc"; timeout 90 $B render --scene $sc --frames 90 --no-images 2>&1 | grep -E "frames via|GPU ms"; done; done | tee $OUT/s60/render.txt
timeout 120 .gpu/tests/gpu_kernels-* both_float --nocapture 2>&1 | grep -E "Runs|Planes|runs against|test result" | tee $OUT/s60/test.txt
