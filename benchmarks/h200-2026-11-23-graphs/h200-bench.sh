#!/usr/bin/env bash
# GPU machine side, BENCHMARKS.md section 0b: the substep as CUDA graphs, the frame's end without idle
# waits, and g2p2g's register cap, against the build before the binned pipeline (.gpu/bin/mpm-base:
# `mpm` built from main at 14073a2), all in one run. Run from a checkout with the built executables in
# .gpu/ as docs/gpu.md ("Running the benchmark scripts") describes; set OUT to a folder for the results.
set -uo pipefail
export PATH=$PATH:/usr/local/cuda/bin
mpm=.gpu/bin/mpm
base=.gpu/bin/mpm-base
out=${OUT:?set OUT to a folder for the results}
date -u
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm,clocks.max.mem --format=csv,noheader
# The driver compiles the PTX on first load and caches it: keep that out of the timed runs.
$base bench --scene bench-65k --steps 100 >/dev/null 2>&1
$mpm bench --scene bench-65k --steps 100 >/dev/null 2>&1

echo "=== step time per phase (mpm bench --steps 2000): before, now, now without graphs"
{
  for s in bench-655k bench-65k dam-break; do
    echo "## $s, base (main at 14073a2)"; $base bench --scene $s --steps 2000
    echo "## $s, base, fixed point"; $base bench --scene $s --steps 2000 --scatter fixed-point
    for sc in float fixed-point; do
      echo "## $s, --scatter $sc"; $mpm bench --scene $s --steps 2000 --scatter $sc
      echo "## $s, --scatter $sc, MPM_CUDA_GRAPHS=0"; MPM_CUDA_GRAPHS=0 $mpm bench --scene $s --steps 2000 --scatter $sc
    done
    echo "## $s, --pipeline report"; $mpm bench --scene $s --steps 2000 --pipeline report
  done
} >"$out/bench.md" 2>&1
grep -E "^## |^\| \*\*total" "$out/bench.md"

echo "=== 16.8M particles, grid 256 (mpm bench --particles 16777216 --grid 256 --steps 300 --warmup 100)"
{
  echo "## base"; $base bench --particles 16777216 --grid 256 --steps 300 --warmup 100
  echo "## now"; $mpm bench --particles 16777216 --grid 256 --steps 300 --warmup 100
} >"$out/bench-16m.md" 2>&1
grep -E "^## |^\| \*\*total" "$out/bench-16m.md"

echo "=== dam break, frame time (mpm render --scene dam-break --frames 90 --size 960x540 --no-images)"
for b in "$base render" "$mpm render" "env MPM_CUDA_GRAPHS=0 $mpm render" "$mpm render --pipeline report"; do
  printf '%s: ' "$b"; $b --scene dam-break --frames 90 --size 960x540 --no-images 2>&1 | grep "frames via"
done

echo "=== mpm run --frames 300 (dam break): wall time against the summed GPU step time; start-up alone"
for b in "$base run" "$mpm run" "env MPM_CUDA_GRAPHS=0 $mpm run"; do
  for frames in 300 0; do
    start=$(date +%s%N); $b --frames $frames >/tmp/run.txt 2>&1; end=$(date +%s%N)
    python3 - /tmp/run.txt "$start" "$end" "$b --frames $frames" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
gpu = sum(int(n) * float(ms) for n, ms in re.findall(r"substeps=\s*(\d+).*?step=([0-9.]+) ms", text))
wall = (int(sys.argv[3]) - int(sys.argv[2])) / 1e9
ratio = f", ratio {wall / (gpu / 1000):.2f}" if gpu else ""
print(f"{sys.argv[4]}: wall {wall:.2f} s, summed GPU step time {gpu / 1000:.2f} s{ratio}")
PY
  done
done

echo "=== ncu, bench-655k (float; fixed point for p2g_tiled)"
for sc in float fixed-point; do
  ncu --clock-control none -k 'regex:^(p2g|p2g_tiled|g2p2g|grid_update_blocks|mirror_walls)$' --launch-skip 300 \
    --launch-count 5 --section SpeedOfLight --section Occupancy --section LaunchStats --csv --page details \
    $mpm bench --scene bench-655k --steps 200 --warmup 0 --scatter $sc >"$out/ncu-655k-$sc.csv" 2>/tmp/ncu.log
done
python3 - "$out"/ncu-655k-*.csv <<'PY'
import csv, sys
want = ["Duration", "Memory Throughput", "Compute (SM) Throughput", "Registers Per Thread", "Achieved Occupancy"]
for path in sys.argv[1:]:
    rows = {}
    with open(path) as f:
        lines = [l for l in f if l.startswith('"')]
    for r in csv.DictReader(lines):
        if r.get("Metric Name") in want:
            rows.setdefault((r["ID"], r.get("Kernel Name", "")), {})[r["Metric Name"]] = r["Metric Value"] + " " + r.get("Metric Unit", "")
    for (_, name), m in sorted(rows.items(), key=lambda kv: int(kv[0][0])):
        print(path.rsplit("/", 1)[-1], name, ", ".join(f"{k} {m.get(k, '-')}" for k in want))
PY
date -u
