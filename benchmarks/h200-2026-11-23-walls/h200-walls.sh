#!/usr/bin/env bash
# GPU machine side, issue "A newcomer's second hour": the walls' new boundary on the GPU beside the build
# before it (.gpu/bin/mpm-base, 3a153e5), and the binary built without NVRTC on a machine without it.
# Run from a checkout with the built executables in .gpu/ (docs/gpu.md, "Running the benchmark
# scripts"), this folder's front.py in .gpu/scripts/; set OUT to a folder for the results.
set -uo pipefail
export PATH=$PATH:/usr/local/cuda/bin
mpm=.gpu/bin/mpm
base=.gpu/bin/mpm-base
nonvrtc=.gpu/bin/mpm-nonvrtc
out=${OUT:?set OUT to a folder for the results}
work=$(mktemp -d)
date -u
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
$mpm bench --scene bench-65k --steps 100 >/dev/null 2>&1
$base bench --scene bench-65k --steps 100 >/dev/null 2>&1

echo "=== 1. the dam break's first second (float, binned): front and gauges, before and now"
for b in base now; do
  exe=$mpm; [ $b = base ] && exe=$base
  $exe run --backend cuda --scene dam-break --frames 60 --every 6 --export $work/$b >$work/$b.log 2>&1 || tail -3 $work/$b.log
done
python3 .gpu/scripts/front.py $work/base $work/now | tee $out/front.md

echo "=== 2. fixed-point runs repeat byte for byte (two runs of the new binary, cmp of every export)"
for scene in dam-break fountain; do
  for r in 1 2; do
    $mpm run --backend cuda --scene $scene --frames 40 --every 10 --scatter fixed-point --export $work/$scene-$r >/dev/null 2>&1
  done
  same=0 files=0
  for f in $work/$scene-1/*.ply; do files=$((files + 1)); cmp -s $f $work/$scene-2/$(basename $f) && same=$((same + 1)); done
  echo "$scene: $same of $files exported frames identical"
done

echo "=== 3. mpm bench --steps 2000 medians (float), before and now"
for s in bench-655k dam-break; do
  for b in "$base" "$mpm"; do echo "## $s, $b"; $b bench --scene $s --steps 2000 | grep -E "mirror|grid_update|\*\*total"; done
done

echo "=== 4. a binary built without NVRTC, with this machine's CUDA toolkit moved aside"
real=$(readlink -f /usr/local/cuda)
mv "$real" "$real.aside" && ldconfig
echo "libnvrtc on the loader path: $(ldconfig -p | grep -c libnvrtc)"
start=$(date +%s%N)
$nonvrtc run --frames 30 >$work/nonvrtc.log 2>&1; rc=$?
end=$(date +%s%N)
grep -E "^scene|^note|^error|frame +30" $work/nonvrtc.log
echo "rc=$rc, wall $(( (end - start) / 1000000 )) ms for 30 frames"
mv "$real.aside" "$real" && ldconfig
rm -rf "$work"
date -u
