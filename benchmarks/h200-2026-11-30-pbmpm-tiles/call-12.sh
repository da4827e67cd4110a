#!/usr/bin/env bash
# Session 27 call 12 (the final read): pb_scatter, one helper for both tiled passes' scatter: the same
# bytes as b8de83f (mpm-old); gpu_pbmpm; pbmpm-1m and the 10M at 8 x 1 against b8de83f.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
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
  if [ "$n" -gt 0 ] && diff -rq /tmp/bytes/$b-mpm-old /tmp/bytes/$b-mpm > /dev/null; then echo "bytes $b: the same, $n files"; else echo "bytes $b: DIFFER ($n files): $(cat $L/bytes-$b.rc | tr '\n' ' ')"; fi
done
timeout 150 $P/gpu_pbmpm > $L/gpu_pbmpm.log 2>&1
echo "gpu_pbmpm: $(grep 'test result' $L/gpu_pbmpm.log)"; grep -E "^test .*(FAILED|ignored)" $L/gpu_pbmpm.log
for s in pbmpm-1m $S/pb-10m-s8-i1.toml; do
  b=$(basename $s .toml)
  for m in mpm-old mpm; do
    timeout 60 $P/$m bench --scene $s --steps 40 --warmup 5 > $L/bench-$b-$m.txt 2>&1
    echo "== $b $m rc $? $(grep -o 'Wall clock: [0-9.]* ms' $L/bench-$b-$m.txt) $(grep -E '^\| (pbmpm_begin|[0-9] x)' $L/bench-$b-$m.txt | cut -d'|' -f3 | tr '\n' ' ')"
  done
done
tar -czf $OUT/logs.tgz -C /tmp logs
