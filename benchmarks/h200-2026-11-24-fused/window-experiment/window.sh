#!/usr/bin/env bash
# one_pass gathering from a shared copy of its tile's node velocities, against the committed one_pass
# (.gpu/ptx-head through MPM_PTX_DIR), in one run.
set -uo pipefail
export PATH=$PATH:/usr/local/cuda/bin
mpm=.gpu/bin/mpm
out=${OUT:?}
$mpm bench --scene bench-65k --steps 100 >/dev/null 2>&1; MPM_PTX_DIR=.gpu/ptx-head $mpm bench --scene bench-65k --steps 100 >/dev/null 2>&1
{
for s in bench-655k dam-break bench-65k; do
  for sc in float fixed-point; do
    for round in 1 2; do
      echo "## $s $sc head round $round"; MPM_PTX_DIR=.gpu/ptx-head $mpm bench --scene $s --steps 2000 --scatter $sc
      echo "## $s $sc window round $round"; $mpm bench --scene $s --steps 2000 --scatter $sc
    done
  done
done
echo "## 16M head"; MPM_PTX_DIR=.gpu/ptx-head $mpm bench --particles 16777216 --grid 256 --steps 300 --warmup 100
echo "## 16M window"; $mpm bench --particles 16777216 --grid 256 --steps 300 --warmup 100
echo "## 16M window fixed-point"; $mpm bench --particles 16777216 --grid 256 --steps 300 --warmup 100 --scatter fixed-point
} > $out/window-bench.md 2>&1
grep -E '^## |^\| \*\*total' $out/window-bench.md
for s in dam-break dam-break-1m; do
  printf "$s head: "; MPM_PTX_DIR=.gpu/ptx-head $mpm render --scene $s --frames 90 --size 960x540 --no-images 2>&1 | grep 'frames via'
  printf "$s window: "; $mpm render --scene $s --frames 90 --size 960x540 --no-images 2>&1 | grep 'frames via'
done
for sc in float fixed-point; do
  ncu --clock-control none -k 'regex:^one_pass$' --launch-skip 150 --launch-count 2 --section SpeedOfLight --section Occupancy --section LaunchStats \
    $mpm bench --scene bench-655k --steps 200 --warmup 0 --scatter $sc > $out/ncu-window-$sc.txt 2>&1
  echo "ncu $sc: $(grep -E '^\s+(Duration|Registers Per Thread|Achieved Occupancy|Memory Throughput|Compute \(SM\) Throughput)' $out/ncu-window-$sc.txt | head -5 | tr -s ' ' | tr '\n' ';')"
done
