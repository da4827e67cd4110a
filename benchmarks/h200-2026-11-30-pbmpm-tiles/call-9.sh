#!/usr/bin/env bash
# Session 27 call 9: the final tree (9efdd53): gpu_pbmpm and gpu_bench, and the bench's header for
# a position-based scene.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
timeout 150 $P/gpu_pbmpm > $L/gpu_pbmpm.log 2>&1 &
timeout 150 $P/gpu_bench > $L/gpu_bench.log 2>&1 &
wait
for t in gpu_pbmpm gpu_bench; do echo "$t: $(grep 'test result' $L/$t.log)"; grep -E "^test .*(FAILED|ignored)" $L/$t.log; done
timeout 60 $P/mpm bench --scene pbmpm-dam-break --steps 40 --warmup 5 > $L/bench-pbmpm-dam-break.txt 2>&1; echo "rc $?"
grep -E "^###|Wall|^\|" $L/bench-pbmpm-dam-break.txt | cut -c1-170
tar -czf $OUT/logs.tgz -C /tmp logs
