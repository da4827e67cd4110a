#!/usr/bin/env bash
# Session 27 call 8: the final kernels (the warp runs' arithmetic pinned in the tiled pass): the
# same bytes as b8de83f (mpm-old) frame by frame; gpu_pbmpm; the benches against b8de83f at 1M and
# 10M beside the explicit solver; headless frames; the water scene beside.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
S=.gpu-exp/scenes
for s in pbmpm-dam-break pbmpm-jelly-drop $S/pb-jd-s8.toml; do
  b=$(basename $s .toml)
  for m in mpm-old mpm; do
    timeout 60 $P/$m run --backend cuda --scene $s --frames 24 --export /tmp/bytes/$b-$m > $L/bytes-$b-$m.log 2>&1; echo "$m rc $?" >> $L/bytes-$b.rc
  done
  n=$(ls /tmp/bytes/$b-mpm | wc -l)
  if [ "$n" -gt 0 ] && diff -rq /tmp/bytes/$b-mpm-old /tmp/bytes/$b-mpm > /dev/null; then echo "bytes $b: the same, $n files ($(du -sb /tmp/bytes/$b-mpm | cut -f1) bytes)"; else echo "bytes $b: DIFFER ($n files): $(cat $L/bytes-$b.rc | tr '\n' ' ') $(diff -rq /tmp/bytes/$b-mpm-old /tmp/bytes/$b-mpm | head -2 | tr '\n' ' ')"; fi
done
timeout 150 $P/gpu_pbmpm --nocapture > $L/gpu_pbmpm.log 2>&1
echo "gpu_pbmpm: $(grep 'test result' $L/gpu_pbmpm.log)"; grep -E "^test .*(FAILED|ignored)|panicked" $L/gpu_pbmpm.log | head
grep RESULT $L/gpu_pbmpm.log | grep -E "frame 30:" | cut -c1-200
for s in pbmpm-dam-break pbmpm-1m $S/pb-1m-s4-i1.toml $S/pb-1m-s4-i2.toml $S/pb-10m-s8-i1.toml $S/pb-10m-s8-i2.toml $S/pb-10m-explicit.toml; do
  b=$(basename $s .toml)
  for m in mpm-old mpm; do
    timeout 60 $P/$m bench --scene $s --steps 40 --warmup 5 > $L/bench-$b-$m.txt 2>&1
    echo "== $b $m rc $? $(grep -o 'Wall clock: [0-9.]* ms' $L/bench-$b-$m.txt) $(grep '^| \*\*total' $L/bench-$b-$m.txt | cut -d'|' -f3-4)"
  done
done
for s in pbmpm-1m; do
  for m in mpm-old mpm; do
    timeout 60 $P/$m render --backend cuda --scene $s --size 960x540 --frames 90 --no-images > $L/render-$s-$m.txt 2>&1; echo "== render $s $m: $(grep 'frames via' $L/render-$s-$m.txt)"
  done
done
STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab1 timeout 100 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene bench-65k" > $L/ab.txt 2>&1
grep '^| `' $L/ab.txt
tar -czf $OUT/logs.tgz -C /tmp logs
