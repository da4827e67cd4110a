#!/usr/bin/env bash
# Device call 5 (issue 42): step_bodies skips the resolve where no body touches anything, and
# copies the contact counts once; the final kernels: step_bodies' own time (ncu), the bench rows
# static against bodies (floating and piled), boats' cost, and gpu_bodies, gpu_lifecycle,
# gpu_kernels.
set -u
cd "$(dirname "$0")/../.." || exit 1
P=/tmp/p5; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_* $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
L=$OUT/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
NCU=$(command -v ncu || ls /usr/local/cuda*/bin/ncu 2>/dev/null | head -1)
for s in boats benches/scenes/bench-boxes-bodies.toml benches/scenes/bench-boxes-pile.toml; do
  timeout 120 $NCU --clock-control none --kernel-name step_bodies --launch-skip 400 --launch-count 5 --metrics gpu__time_duration.sum $P/mpm run --scene $s --frames 12 > $L/ncu-$(basename $s .toml).txt 2>&1
  grep -E "gpu__time_duration" $L/ncu-$(basename $s .toml).txt | head -3 | sed "s|^|$(basename $s .toml): |"
done
B=benches/scenes
for r in 1 2; do for s in boxes-static boxes-bodies boxes-pile-static boxes-pile; do
  timeout 60 $P/mpm bench --scene $B/bench-$s.toml --steps 1000 > $L/$s-$r.txt 2>&1
  echo "$s $r: $(grep -E '^\| mirror_walls' $L/$s-$r.txt | awk -F'|' '{print "grid", $3}') $(grep -E '^\| \*\*total' $L/$s-$r.txt | awk -F'|' '{print "total", $3}')"
done; done
timeout 100 $P/mpm run --scene boats --frames 300 > $L/boats-run.txt 2>&1; tail -1 $L/boats-run.txt | cut -c1-300
timeout 330 bash scripts/gpu-tests.sh --tests $P/tests --mpm $P/mpm --out $L/tests --timeout 320 > $L/suite.txt 2>&1
tail -4 $L/suite.txt; grep -h "RESULT [0-9]* cells\|cube [0-9]:\|panicked" $L/tests/*.log | head -12
tar -czf $OUT/logs.tgz -C $L . && rm -rf $L
