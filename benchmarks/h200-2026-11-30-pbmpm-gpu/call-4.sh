#!/usr/bin/env bash
# Session 25 call 4: gpu_pbmpm with every law reported; soundness of the 1M dam break at 8 substeps.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
timeout 300 $P/gpu_pbmpm --nocapture every_law > $L/gpu_pbmpm.log 2>&1
grep -E "test result|FAILED|RESULT" $L/gpu_pbmpm.log | head -90
S=.gpu-exp/scenes
for s in $S/pb-1m-s8-i2.toml $S/pb-1m-s8-i4.toml; do
  timeout 120 $P/mpm run --backend cuda --scene $s --frames 90 > $L/run-$(basename $s .toml).txt 2>&1; echo "== run $s rc $?"
  awk 'NR%10==2 || /error/' $L/run-$(basename $s .toml).txt | cut -c1-190; tail -n 1 $L/run-$(basename $s .toml).txt
done
tar -czf $OUT/logs.tgz -C /tmp logs
