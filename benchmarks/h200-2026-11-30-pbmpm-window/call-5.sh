#!/usr/bin/env bash
# Session 29 call 5: the final build (pbmpm graphs, paced stepping beside the draw): the GPU tests that
# its changes reach; mpm bench before (main b7ec501, mpm-old) and after; pbmpm-1m and dam-break-1m
# headless over the spans their window runs simulate (18.1 s, 11.6 s), by the substeps' CUDA events.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0
L=/tmp/logs; rm -rf $L; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
for t in gpu_pbmpm gpu_kernels gpu_physics gpu_render gpu_bodies gpu_lifecycle; do
  timeout 240 .gpu/tests/$t > $L/test-$t.log 2>&1; echo "== test $t rc $?"; grep -E "^test result|FAILED|RESULT pbmpm GPU (graphs|pacing)" $L/test-$t.log | tail -4
done
OUT=$L/bench STEPS=1000 WARMUP=100 RUNS=2 timeout 240 bash scripts/bench-ab.sh .gpu/bin/mpm-old .gpu/bin/mpm "--scene bench-65k" "--scene dam-break" "--scene pbmpm-1m" "--scene pbmpm-dam-break" > $L/bench.txt 2>&1; echo "== bench rc $?"; tail -9 $L/bench.txt
for sf in pbmpm-1m:1086 dam-break-1m:700; do s=${sf%%:*} f=${sf##*:}
  timeout 60 .gpu/bin/mpm run --backend cuda --scene $s --frames $f > $L/run-$s.log 2>&1; echo "== run $s $f frames rc $?: $(grep '^time:' $L/run-$s.log)"
done
tar -czf $OUT/logs.tgz -C /tmp logs
