#!/usr/bin/env bash
# Session 27 call 2: the position-based substep kernel by kernel (ncu's durations, clocks as they run)
# at 1M (4 iterations) and 10M (1 iteration), and pbmpm_pass's speed of light at 1M.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
NCU=$(command -v ncu || ls /opt/nvidia/nsight-compute/*/ncu /usr/local/cuda*/bin/ncu 2>/dev/null | head -1)
L=/tmp/logs; mkdir -p $L; echo "ncu: $NCU" | tee $L/ncu.txt
S=.gpu-exp/scenes
for s in pbmpm-1m $S/pb-10m-s8-i1.toml; do
  b=$(basename $s .toml)
  timeout 150 $NCU --clock-control none --metrics gpu__time_duration.sum --launch-skip 300 --launch-count 120 --csv \
    $P/mpm bench --scene $s --steps 12 --warmup 2 > $L/ncu-$b.csv 2> $L/ncu-$b.err
  echo "== $b rc $?"
  python3 - $L/ncu-$b.csv <<'PY'
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
done
timeout 120 $NCU --clock-control none --section SpeedOfLight --section Occupancy --section LaunchStats -k regex:pbmpm_pass --launch-skip 8 --launch-count 2 \
  $P/mpm bench --scene pbmpm-1m --steps 3 --warmup 1 > $L/ncu-pass.txt 2>&1
grep -E "pbmpm_pass|Duration|Throughput|Registers|Achieved Occupancy|Theoretical Occupancy|Block Limit" $L/ncu-pass.txt | head -40
tar -czf $OUT/logs.tgz -C /tmp logs
