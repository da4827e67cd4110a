#!/usr/bin/env bash
# GPU machine side, the binned pipeline (BENCHMARKS.md section 0): the GPU tests, compute-sanitizer on
# the new kernels, and every before/after figure in one run, with the previous build (.gpu/bin/mpm-base:
# `mpm` built from main at 14073a2) beside the new one. Run from a checkout with the built executables
# in .gpu/ as docs/gpu.md ("Running the benchmark scripts") describes; set OUT to a folder for the
# results.
set -uo pipefail
export PATH=$PATH:/usr/local/cuda/bin
mpm=.gpu/bin/mpm
base=.gpu/bin/mpm-base
out=${OUT:?set OUT to a folder for the results}
date -u
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm,clocks.max.mem --format=csv,noheader

echo "=== tests (every test executable)"
status=0
for t in .gpu/tests/*; do
  [ -f "$t" ] && [ -x "$t" ] && [ "$(basename "$t")" != all ] || continue
  echo "=== $t"; MPM_BIN=$PWD/$mpm "$t" || status=$?
done >"$out/tests.log" 2>&1
echo "tests exit $status"; grep -E "^test result|not run|FAILED|panicked" "$out/tests.log"

echo "=== compute-sanitizer (binned pipeline, both scatters)"
for sc in float fixed-point; do
  for tool in memcheck racecheck; do
    printf '%s %s: ' $tool $sc
    timeout 200 compute-sanitizer --tool $tool --error-exitcode 9 $mpm run --scene dam-break-coarse \
      --backend cuda --frames 2 --scatter $sc >/tmp/sanitizer.log 2>&1
    echo "exit $? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/sanitizer.log | tail -1)"
  done
done

echo "=== step time per phase (mpm bench --steps 2000), before and after"
{
  echo "## base (main at 14073a2)"; $base bench --steps 2000
  echo "## base, fixed point"; $base bench --steps 2000 --scatter fixed-point
  for p in binned report; do for sc in float fixed-point; do
    echo "## --pipeline $p --scatter $sc"; $mpm bench --steps 2000 --pipeline $p --scatter $sc
  done; done
  echo "## base, dam-break"; $base bench --scene dam-break --steps 2000
  for p in binned report; do echo "## --pipeline $p, dam-break"; $mpm bench --scene dam-break --steps 2000 --pipeline $p; done
} >"$out/bench.md" 2>&1
grep -E "^## |^### |^\| \*\*total" "$out/bench.md"

echo "=== 16.8M particles, grid 256 (mpm bench --particles 16777216 --grid 256 --steps 300 --warmup 100)"
{
  echo "## base"; $base bench --particles 16777216 --grid 256 --steps 300 --warmup 100
  for p in binned report; do echo "## --pipeline $p"; $mpm bench --particles 16777216 --grid 256 --steps 300 --warmup 100 --pipeline $p; done
} >"$out/bench-16m.md" 2>&1
grep -E "^## |^### |^\| \*\*total" "$out/bench-16m.md"

echo "=== scaling sweep, binned pipeline (mpm bench --scene bench-65k --steps 200 --sweep)"
$mpm bench --scene bench-65k --steps 200 --sweep --json "$out/sweep.json" --overwrite >"$out/sweep.md" 2>&1
grep -E "^\| [0-9]" "$out/sweep.md"

echo "=== dam break, frame time (mpm render --scene dam-break --frames 90 --size 960x540 --no-images)"
for b in "$base render" "$mpm render --pipeline binned" "$mpm render --pipeline report"; do
  printf '%s: ' "$b"; $b --scene dam-break --frames 90 --size 960x540 --no-images 2>&1 | grep "frames via"
done

echo "=== mpm run --frames 300 (dam break): wall time against the summed GPU step time"
for b in "$base run" "$mpm run --pipeline binned" "$mpm run --pipeline report"; do
  start=$(date +%s%N); $b --frames 300 >/tmp/run.txt 2>&1; end=$(date +%s%N)
  python3 - /tmp/run.txt "$start" "$end" "$b" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
gpu = sum(int(n) * float(ms) for n, ms in re.findall(r"substeps=\s*(\d+).*?step=([0-9.]+) ms", text))
wall = (int(sys.argv[3]) - int(sys.argv[2])) / 1e9
print(f"{sys.argv[4]}: wall {wall:.2f} s, summed GPU step time {gpu / 1000:.2f} s, ratio {wall / (gpu / 1000):.2f}")
PY
done

echo "=== ncu, bench-655k, binned pipeline (float; fixed point for p2g_tiled)"
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
        name = r.get("Kernel Name", "")
        if r.get("Metric Name") in want and name not in ("p2g_tiled",) or (name == "p2g_tiled" and "fixed" in path and r.get("Metric Name") in want):
            rows.setdefault((r["ID"], name), {})[r["Metric Name"]] = r["Metric Value"] + " " + r.get("Metric Unit", "")
    for (_, name), m in sorted(rows.items(), key=lambda kv: int(kv[0][0])):
        print(path.rsplit("/", 1)[-1], name, ", ".join(f"{k} {m.get(k, '-')}" for k in want))
PY

echo "=== CPU backends on the host's cores (mpm bench --backend cpu|cpu-parallel)"
nproc
for b in cpu cpu-parallel; do
  $mpm bench --backend $b --scene bench-65k --scene dam-break --steps 200 --warmup 20 2>&1 | grep -E "^### |^\| \*\*total"
done
date -u
