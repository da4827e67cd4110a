#!/usr/bin/env bash
# GPU machine side, issue "The substep's house": proof that the restructuring changed nothing.
# Compares `mpm` built from this commit (.gpu/bin/mpm) with `mpm` built from main before the
# restructuring (.gpu/bin/mpm-base, 3a153e5), in one run on one device:
#   1. fixed-point runs of five presets are byte-identical (every exported PLY, cmp);
#   2. `mpm bench` float medians, old and new alternated twice, so the spread between the two runs
#      of one binary is the noise the old/new difference is read against;
#   3. the dam break's frame time headless and `mpm run`'s wall time against its GPU step time.
# Run from a checkout with the built executables in .gpu/ (docs/gpu.md, "Running the benchmark
# scripts"); set OUT to a folder for the results.
set -uo pipefail
mpm=.gpu/bin/mpm
base=.gpu/bin/mpm-base
out=${OUT:?set OUT to a folder for the results}
date -u
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
$base bench --scene bench-65k --steps 100 >/dev/null 2>&1
$mpm bench --scene bench-65k --steps 100 >/dev/null 2>&1

echo "=== 1. fixed-point runs, old against new (cmp of every exported PLY)"
work=$(mktemp -d)
status=0
for run in "dam-break 60" "dam-break-obstacle 60" "fountain 120" "tap 120" "wave-tank 60" "dam-break 30 --pipeline report"; do
  set -- $run
  scene=$1 frames=$2; shift 2
  tag=$scene${1:+-report}
  for b in base new; do
    exe=$mpm; [ $b = base ] && exe=$base
    $exe run --backend cuda --scene $scene --frames $frames --scatter fixed-point --export $work/$tag-$b --every 10 "$@" \
      >$work/$tag-$b.log 2>&1 || { echo "$tag $b: run failed"; tail -3 $work/$tag-$b.log; status=1; }
  done
  files=0 same=0
  for f in $work/$tag-base/*.ply; do
    files=$((files + 1))
    cmp -s "$f" "$work/$tag-new/$(basename "$f")" && same=$((same + 1))
  done
  verdict=identical; [ $files -gt 0 ] && [ $same = $files ] || { verdict=DIFFERENT; status=1; }
  echo "$tag ($frames frames, fixed point${1:+, $*}): $same of $files exported frames byte-identical: $verdict"
done
rm -rf "$work"

echo "=== 2. mpm bench --steps 2000 medians (float), old/new/old/new"
{
  for s in bench-655k bench-65k dam-break; do
    for round in 1 2; do
      echo "## $s, old (3a153e5), round $round"; $base bench --scene $s --steps 2000
      echo "## $s, new, round $round"; $mpm bench --scene $s --steps 2000
    done
  done
  echo "## bench-655k, new, fixed point"; $mpm bench --scene bench-655k --steps 2000 --scatter fixed-point
  echo "## 16.8M particles, grid 256, old"; $base bench --particles 16777216 --grid 256 --steps 300 --warmup 100
  echo "## 16.8M particles, grid 256, new"; $mpm bench --particles 16777216 --grid 256 --steps 300 --warmup 100
} >"$out/bench.md" 2>&1
grep -E "^## |^\| \*\*total" "$out/bench.md"

echo "=== 3. frame time and run overhead (new; old beside it)"
for b in "$base" "$mpm"; do
  printf '%s render: ' "$b"
  $b render --scene dam-break --frames 90 --size 960x540 --no-images 2>&1 | grep "frames via"
  start=$(date +%s%N); $b run --frames 300 >/tmp/run.txt 2>&1; end=$(date +%s%N)
  python3 - /tmp/run.txt "$start" "$end" "$b run --frames 300" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
gpu = sum(int(n) * float(ms) for n, ms in re.findall(r"substeps=\s*(\d+).*?step=([0-9.]+) ms", text))
wall = (int(sys.argv[3]) - int(sys.argv[2])) / 1e9
print(f"{sys.argv[4]}: wall {wall:.2f} s, summed GPU step time {gpu / 1000:.2f} s, ratio {wall / (gpu / 1000):.2f}")
PY
done
date -u
exit $status
