#!/usr/bin/env bash
# Session 27 call 6: the final kernels (the gather rounded as the CPU rounds): gpu_pbmpm; the
# position-based benches against b8de83f (mpm-old) at 1M and 10M, 1/2/4 iterations, beside the
# explicit solver; headless frames; the water scene beside.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
timeout 150 $P/gpu_pbmpm --nocapture > $L/gpu_pbmpm.log 2>&1
echo "gpu_pbmpm: $(grep 'test result' $L/gpu_pbmpm.log)"; grep -E "^test .*(FAILED|ignored)|panicked" $L/gpu_pbmpm.log | head
grep RESULT $L/gpu_pbmpm.log | grep "frame 30:" | cut -c1-200
S=.gpu-exp/scenes
for s in pbmpm-dam-break pbmpm-1m $S/pb-1m-s4-i1.toml $S/pb-1m-s4-i2.toml $S/pb-10m-s8-i1.toml $S/pb-10m-s8-i2.toml $S/pb-10m-explicit.toml; do
  b=$(basename $s .toml)
  for m in mpm-old mpm; do
    timeout 60 $P/$m bench --scene $s --steps 40 --warmup 5 > $L/bench-$b-$m.txt 2>&1
    echo "== $b $m rc $? $(grep -o 'Wall clock: [0-9.]* ms' $L/bench-$b-$m.txt) $(grep '^| \*\*total' $L/bench-$b-$m.txt | cut -d'|' -f3-4)"
  done
done
for s in pbmpm-1m dam-break-1m; do
  for m in mpm-old mpm; do
    timeout 60 $P/$m render --backend cuda --scene $s --size 960x540 --frames 90 --no-images > $L/render-$s-$m.txt 2>&1; echo "== render $s $m: $(grep 'frames via' $L/render-$s-$m.txt)"
  done
done
STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab1 timeout 100 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene bench-65k" > $L/ab.txt 2>&1
grep '^| `' $L/ab.txt
tar -czf $OUT/logs.tgz -C /tmp logs
