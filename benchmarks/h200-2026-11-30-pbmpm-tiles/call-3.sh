#!/usr/bin/env bash
# Session 27 call 3: pbmpm_scatter (the iteration's pass through a shared tile per bin, bins every
# substep): gpu_pbmpm; the position-based benches against b8de83f (mpm-old), the water scene beside;
# the new substep kernel by kernel (ncu).
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm PATH=$PATH:/usr/local/cuda/bin
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
timeout 150 $P/gpu_pbmpm --nocapture > $L/gpu_pbmpm.log 2>&1
echo "gpu_pbmpm: $(grep 'test result' $L/gpu_pbmpm.log)"; grep -E "^test .*(FAILED|ignored)|panicked" $L/gpu_pbmpm.log | head
S=.gpu-exp/scenes
for s in pbmpm-1m $S/pb-1m-s4-i1.toml $S/pb-10m-s8-i1.toml $S/pb-10m-s8-i2.toml; do
  b=$(basename $s .toml)
  for m in mpm-old mpm; do
    timeout 60 $P/$m bench --scene $s --steps 40 --warmup 5 > $L/bench-$b-$m.txt 2>&1
    echo "== $b $m rc $? $(grep -o 'Wall clock: [0-9.]* ms' $L/bench-$b-$m.txt)"
    grep -E "^\| (bins|pbmpm|[0-9] x|\*\*total)" $L/bench-$b-$m.txt | cut -d'|' -f2-4
  done
done
STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab1 timeout 100 bash scripts/bench-ab.sh $P/mpm-old $P/mpm "--scene bench-65k" > $L/ab.txt 2>&1
grep '^| `' $L/ab.txt
NCU=/usr/local/cuda/bin/ncu
timeout 100 $NCU --clock-control none --metrics gpu__time_duration.sum --launch-skip 150 --launch-count 60 --csv \
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
timeout 100 $NCU --clock-control none --section SpeedOfLight --section Occupancy --section LaunchStats -k regex:pbmpm_scatter --launch-skip 8 --launch-count 1 \
  $P/mpm bench --scene pbmpm-1m --steps 3 --warmup 1 > $L/ncu-scatter.txt 2>&1
grep -E "Duration|Throughput|Registers|Achieved Occupancy|Theoretical Occupancy|Block Limit|Shared Memory" $L/ncu-scatter.txt | head -24
tar -czf $OUT/logs.tgz -C /tmp logs
