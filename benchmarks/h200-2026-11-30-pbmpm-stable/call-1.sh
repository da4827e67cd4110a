#!/usr/bin/env bash
# Session 28 call 1: the 10M position-based substep kernel by kernel (ncu durations) with its bench;
# the viewer with real-time pacing on pbmpm-1m, uncapped and at --max-fps 60, and the 10M in the window.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
S=benchmarks/h200-2026-11-30-pbmpm-stable/scenes
timeout 60 $P/mpm bench --scene $S/pb-10m-s8-i1.toml --steps 40 --warmup 5 > $L/bench-10m.txt 2>&1
echo "bench rc $? $(grep -o 'Wall clock: [0-9.]* ms' $L/bench-10m.txt)"; grep "^| " $L/bench-10m.txt | cut -d'|' -f2-3
timeout 150 ncu --clock-control none --metrics gpu__time_duration.sum --launch-skip 120 --launch-count 60 --csv \
    $P/mpm bench --scene $S/pb-10m-s8-i1.toml --steps 12 --warmup 2 > $L/ncu-10m.csv 2> $L/ncu-10m.err
echo "ncu rc $?"
python3 - $L/ncu-10m.csv <<'PY'
import csv, sys, collections
rows = [r for r in csv.reader(open(sys.argv[1])) if len(r) > 10 and not r[0].startswith("==")]
h = next(r for r in rows if "Kernel Name" in r); ki = h.index("Kernel Name"); vi = h.index("Metric Value")
t = collections.defaultdict(list)
for r in rows:
    if r is h: continue
    try: t[r[ki].split("(")[0]].append(float(r[vi].replace(",", "")))
    except (ValueError, IndexError): pass
tot = sum(sum(v) for v in t.values())
for k, v in sorted(t.items(), key=lambda kv: -sum(kv[1])):
    print(f"{k:40s} n={len(v):4d} mean={sum(v)/len(v)/1e3:9.1f} us  share={sum(v)/tot*100:5.1f} %")
PY
run_view() { # name scene frames extra...
  local name=$1 scene=$2 frames=$3; shift 3
  timeout 170 bash scripts/view-on-gpu.sh --scene $scene --frames $frames --fixed-frames 0 --mpm $P/mpm --x11 .gpu/x11/root.tar.xz --out /tmp/win-$name --timeout 150 -- "$@" > $L/window-$name.txt 2>&1
  echo "== window $name rc=$?"; grep -E "^viewer: (timed|mean)" /tmp/win-$name/view.log
  cp /tmp/win-$name/view.log $L/view-$name.log 2>/dev/null; cp /tmp/win-$name/window.png $OUT/window-$name.png 2>/dev/null
}
run_view 1m-uncapped pbmpm-1m 600
run_view 1m-fps60 pbmpm-1m 400 --max-fps 60
run_view 10m-fps60 $S/pb-10m-s8-i1.toml 150 --max-fps 60
tar -czf $OUT/logs.tgz -C /tmp logs
