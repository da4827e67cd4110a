#!/usr/bin/env bash
# Session 25 call 1: the position-based substep on CUDA: its GPU tests, the spawn test, pbmpm benches,
# and the water scenes against the build before (mpm-old, 272cfba's code) in the same call.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
timeout 300 $P/gpu_pbmpm --nocapture > $OUT/gpu_pbmpm.log 2>&1 &
timeout 250 $P/gpu_kernels > $OUT/gpu_kernels.log 2>&1 &
wait
grep -E "test result|FAILED|panicked|RESULT" $OUT/gpu_pbmpm.log | head -60
grep -E "test result|FAILED|panicked" $OUT/gpu_kernels.log | head
for s in pbmpm-dam-break .gpu-exp/scenes/pb-1m.toml .gpu-exp/scenes/pb-10m-i1.toml .gpu-exp/scenes/pb-10m-i2.toml .gpu-exp/scenes/pb-10m.toml; do
  timeout 100 $P/mpm bench --scene $s --steps 100 --warmup 10 > $OUT/bench-$(basename $s .toml).txt 2>&1
  echo "== $s rc $?"; grep -E "^\| |Wall clock|substep" $OUT/bench-$(basename $s .toml).txt | head -14
done
STEPS=1000 WARMUP=100 RUNS=1 OUT=/tmp/ab1 timeout 120 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene bench-65k" "--scene dam-break" > $OUT/ab.txt 2>&1
grep '^| `' $OUT/ab.txt
timeout 60 $P/mpm render --backend cuda --scene pbmpm-dam-break --size 960x540 --frames 90 --no-images > $OUT/render-pb.txt 2>&1; tail -5 $OUT/render-pb.txt
