#!/usr/bin/env bash
# Session 25 call 2: call 1 after the grid pass's fix (own displacement only where the walls grip).
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
MPM_CUDA_SYNC=1 timeout 60 $P/mpm bench --scene pbmpm-dam-break --steps 20 --warmup 2 > $L/sync.txt 2>&1; echo "sync rc $?"; tail -3 $L/sync.txt
timeout 400 $P/gpu_pbmpm --nocapture > $L/gpu_pbmpm.log 2>&1
grep -E "test result|FAILED|panicked|RESULT" $L/gpu_pbmpm.log | head -70
for s in pbmpm-dam-break .gpu-exp/scenes/pb-1m.toml .gpu-exp/scenes/pb-10m-i1.toml .gpu-exp/scenes/pb-10m-i2.toml .gpu-exp/scenes/pb-10m.toml; do
  timeout 100 $P/mpm bench --scene $s --steps 100 --warmup 10 > $L/bench-$(basename $s .toml).txt 2>&1
  echo "== $s rc $?"; grep -E "^\| |Wall clock|substep" $L/bench-$(basename $s .toml).txt | head -14
done
timeout 60 $P/mpm render --backend cuda --scene pbmpm-dam-break --size 960x540 --frames 90 --no-images > $L/render-pb.txt 2>&1; tail -5 $L/render-pb.txt
tar -czf $OUT/logs.tgz -C /tmp logs
