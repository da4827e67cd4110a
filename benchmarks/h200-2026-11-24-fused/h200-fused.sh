#!/usr/bin/env bash
# GPU machine side, BENCHMARKS.md section 0e: the fused pipeline (one particle pass per substep, the
# density advected) against the binned pipeline as it stood before it (`before`: this binary with
# main's kernels at 1640088 loaded from .gpu/ptx-main through MPM_PTX_DIR, `--pipeline binned`), the
# binned pipeline now, and the report's, all in one run. Run from a checkout with the built
# executables in .gpu/ as docs/testing.md describes; set OUT to a folder for the results.
# .gpu/ptx-main holds main's compute_90 PTX at 1640088 but lifecycle's (whose emit arguments changed):
#   mkdir -p .gpu/ptx-main; for f in $(git ls-tree --name-only 1640088 kernels/ptx/ | grep compute_90 \
#     | grep -v lifecycle); do git show 1640088:$f > .gpu/ptx-main/$(basename $f); done
# (the binned kernels' PTX instructions are unchanged since; the `before` and `binned` rows agree).
set -uo pipefail
export PATH=$PATH:/usr/local/cuda/bin
mpm=${MPM:-.gpu/bin/mpm}
out=${OUT:?set OUT to a folder for the results}
before() { MPM_PTX_DIR=.gpu/ptx-main $mpm "$@" --pipeline binned; }
date -u
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm,clocks.max.mem --format=csv,noheader
# The driver compiles the PTX on first load and caches it: keep that out of the timed runs.
$mpm bench --scene bench-65k --steps 100 >/dev/null 2>&1
before bench --scene bench-65k --steps 100 >/dev/null 2>&1

echo "=== step time per phase (mpm bench --steps 2000)"
{
  for s in bench-655k bench-65k dam-break; do
    for sc in float fixed-point; do
      echo "## $s, before, --scatter $sc"; before bench --scene $s --steps 2000 --scatter $sc
      echo "## $s, --pipeline binned --scatter $sc"; $mpm bench --scene $s --steps 2000 --pipeline binned --scatter $sc
      echo "## $s, --pipeline fused --scatter $sc"; $mpm bench --scene $s --steps 2000 --pipeline fused --scatter $sc
    done
    echo "## $s, --pipeline report"; $mpm bench --scene $s --steps 2000 --pipeline report
  done
} >"$out/bench.md" 2>&1
grep -E "^## |^\| \*\*total" "$out/bench.md"

echo "=== 16.8M particles, grid 256 (mpm bench --particles 16777216 --grid 256 --steps 300 --warmup 100)"
{
  echo "## before"; before bench --particles 16777216 --grid 256 --steps 300 --warmup 100
  echo "## --pipeline fused"; $mpm bench --particles 16777216 --grid 256 --steps 300 --warmup 100 --pipeline fused
  echo "## --pipeline fused --scatter fixed-point"; $mpm bench --particles 16777216 --grid 256 --steps 300 --warmup 100 --scatter fixed-point
} >"$out/bench-16m.md" 2>&1
grep -E "^## |^\| \*\*total" "$out/bench-16m.md"

echo "=== frame time (mpm render --frames 90 --no-images)"
for scene in dam-break dam-break-1m; do
  for size in 960x540 1920x1080; do
    printf '%s %s before: ' "$scene" "$size"
    before render --scene $scene --frames 90 --size $size --no-images 2>&1 | grep "frames via"
    printf '%s %s fused: ' "$scene" "$size"
    $mpm render --scene $scene --frames 90 --size $size --no-images 2>&1 | grep "frames via"
  done
done

echo "=== mpm run --frames 300 (dam break): wall time against the summed GPU step time"
for who in before fused; do
  start=$(date +%s%N)
  if [ $who = before ]; then before run --frames 300 >/tmp/run.txt 2>&1; else $mpm run --frames 300 >/tmp/run.txt 2>&1; fi
  end=$(date +%s%N)
  python3 - /tmp/run.txt "$start" "$end" "$who" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
gpu = sum(int(n) * float(ms) for n, ms in re.findall(r"substeps=\s*(\d+).*?step=([0-9.]+) ms", text))
wall = (int(sys.argv[3]) - int(sys.argv[2])) / 1e9
print(f"{sys.argv[4]}: wall {wall:.2f} s, summed GPU step time {gpu / 1000:.2f} s, ratio {wall / (gpu / 1000):.2f}")
PY
done

echo "=== ncu, bench-655k (a substep after 100)"
for sc in float fixed-point; do
  ncu --clock-control none -k 'regex:^(one_pass|grid_update_blocks|mirror_walls)$' --launch-skip 400 \
    --launch-count 4 --section SpeedOfLight --section Occupancy --section LaunchStats --csv --page details \
    $mpm bench --scene bench-655k --steps 200 --warmup 0 --scatter $sc >"$out/ncu-655k-fused-$sc.csv" 2>/tmp/ncu.log
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

echo "=== the viewer, windowed (scripts/view-on-gpu.sh --frames 300, the dam break, surface)"
if [ -f .gpu/x11/root.tar.xz ]; then
  for who in fused before; do
    if [ $who = before ]; then extra="-- --pipeline binned"; export MPM_PTX_DIR=.gpu/ptx-main; else extra=""; unset MPM_PTX_DIR; fi
    bash scripts/view-on-gpu.sh --frames 300 --out "$out/view-$who" $extra >/dev/null 2>&1
    echo "$who: $(grep -E 'mean draw interval' "$out/view-$who/view.log" | tail -1 | tr '\n' ' ')"
  done
  unset MPM_PTX_DIR
else
  echo "no .gpu/x11/root.tar.xz (scripts/pack-x11.sh): not run"
fi
date -u
