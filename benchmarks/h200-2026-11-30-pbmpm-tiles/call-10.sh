#!/usr/bin/env bash
# Session 27 call 10: pbmpm_begin through the bins' tiles too: the same bytes as b8de83f (mpm-old);
# gpu_pbmpm; the benches against b8de83f at 1M and 10M; ncu's durations at 1M.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm PATH=$PATH:/usr/local/cuda/bin
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
for s in pbmpm-dam-break pbmpm-1m $S/pb-1m-s4-i1.toml $S/pb-1m-s4-i2.toml $S/pb-10m-s8-i1.toml $S/pb-10m-s8-i2.toml; do
  b=$(basename $s .toml)
  for m in mpm-old mpm; do
    timeout 60 $P/$m bench --scene $s --steps 40 --warmup 5 > $L/bench-$b-$m.txt 2>&1
    echo "== $b $m rc $? $(grep -o 'Wall clock: [0-9.]* ms' $L/bench-$b-$m.txt) $(grep '^| \*\*total' $L/bench-$b-$m.txt | cut -d'|' -f3-4)"
  done
  grep "pbmpm_begin" $L/bench-$b-mpm.txt | cut -d'|' -f3
done
for m in mpm-old mpm; do
  timeout 60 $P/$m render --backend cuda --scene pbmpm-1m --size 960x540 --frames 90 --no-images > $L/render-pbmpm-1m-$m.txt 2>&1; echo "== render pbmpm-1m $m: $(grep 'frames via' $L/render-pbmpm-1m-$m.txt)"
done
timeout 100 ncu --clock-control none --metrics gpu__time_duration.sum --launch-skip 150 --launch-count 60 --csv \
    $P/mpm bench --scene pbmpm-1m --steps 8 --warmup 2 > $L/ncu-1m.csv 2> $L/ncu-1m.err
python3 - $L/ncu-1m.csv <<'PY'
import csv, sys, collections
rows = [r for r in csv.reader(open(sys.argv[1])) if len(r) > 10]
h = rows[0]; ki = h.index("Kernel Name"); vi = h.index("Metric Value")
t = collections.defaultdict(list)
for r in rows[1:]:
    try: t[r[ki].split("(")[0]].append(float(r[vi].replace(",", "")))
    except ValueError: pass
tot = sum(sum(v) for v in t.values())
for k, v in sorted(t.items(), key=lambda kv: -sum(kv[1])):
    print(f"{k:40s} n={len(v):4d} mean={sum(v)/len(v)/1e3:9.1f} us  share={sum(v)/tot*100:5.1f} %")
PY
tar -czf $OUT/logs.tgz -C /tmp logs
