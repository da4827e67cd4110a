#!/usr/bin/env bash
# Session 25 call 3: the drift correction's ramp; gpu_pbmpm; pbmpm benches at 1M and 10M particles
# (1, 2, 4 iterations) beside the explicit solver on the same 10M scene; 60-frame runs for soundness.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
timeout 300 $P/gpu_pbmpm --nocapture > $L/gpu_pbmpm.log 2>&1
grep -E "test result|FAILED|panicked|RESULT" $L/gpu_pbmpm.log | grep -v "t = " | head -70
S=.gpu-exp/scenes
for s in pbmpm-dam-break $S/pb-1m-s4-i1.toml $S/pb-1m-s4-i2.toml $S/pb-1m-s4-i4.toml $S/pb-10m-s8-i1.toml $S/pb-10m-s8-i2.toml $S/pb-10m-s8-i4.toml; do
  timeout 100 $P/mpm bench --scene $s --steps 100 --warmup 10 > $L/bench-$(basename $s .toml).txt 2>&1
  echo "== $s rc $?"; grep -E "^\| |Wall clock" $L/bench-$(basename $s .toml).txt | grep -v "none under" | head -8
done
timeout 100 $P/mpm bench --scene $S/pb-10m-explicit.toml --steps 100 --warmup 10 > $L/bench-explicit.txt 2>&1; echo "== explicit rc $?"; grep -E "^\| \*\*|Wall clock|substep " $L/bench-explicit.txt | head
for s in $S/pb-1m-s4-i4.toml $S/pb-10m-s8-i4.toml $S/pb-1m.toml; do
  timeout 120 $P/mpm run --backend cuda --scene $s --frames 60 > $L/run-$(basename $s .toml).txt 2>&1; echo "== run $s rc $?"
  awk 'NR%10==2 || /error/' $L/run-$(basename $s .toml).txt | cut -c1-190; tail -n 1 $L/run-$(basename $s .toml).txt
done
tar -czf $OUT/logs.tgz -C /tmp logs
