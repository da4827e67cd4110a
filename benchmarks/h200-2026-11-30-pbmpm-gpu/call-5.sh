#!/usr/bin/env bash
# Session 25 call 5: the drift correction's weight from the stencil's shortfall of fill (continuous);
# gpu_pbmpm whole.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
timeout 300 $P/gpu_pbmpm --nocapture > $L/gpu_pbmpm.log 2>&1
grep -E "test result|FAILED|RESULT|panicked" $L/gpu_pbmpm.log | grep -v "t = " | cut -c1-250 | head -90
S=.gpu-exp/scenes
for s in $S/pb-1m-s4-i4.toml $S/pb-1m-s8-i2.toml; do
  timeout 120 $P/mpm run --backend cuda --scene $s --frames 90 > $L/run-$(basename $s .toml).txt 2>&1; echo "== run $s rc $?"
  awk 'NR%10==2 || /error/' $L/run-$(basename $s .toml).txt | cut -c1-150; tail -n 1 $L/run-$(basename $s .toml).txt
done
tar -czf $OUT/logs.tgz -C /tmp logs
