#!/usr/bin/env bash
# Call 3 (2026-11-27, materials): water-only speed with one_pass's water entries against 12e54ac,
# the fixed-point particles against 12e54ac property by property, the GPU tests, the presets' cost
# and pictures. Everything under $OUT/r goes back as one archive.
set -u
R=$OUT/r; mkdir -p $R .gpu/bin /tmp/base .gpu/tests
xz -dc .gpu-pack3/mpm.xz > .gpu/bin/mpm && chmod +x .gpu/bin/mpm
xz -dc .gpu-pack3/mpm-base.xz > /tmp/base/mpm && chmod +x /tmp/base/mpm
tar xJf .gpu-pack3/tests.tar.xz -C .gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $R/device.txt
for b in /tmp/base/mpm .gpu/bin/mpm; do $b bench --scene bench-65k --steps 20 --warmup 5 > /dev/null 2>&1; done
echo "=== bench a/b"
OUT=$R/bench-ab RUNS=3 bash scripts/bench-ab.sh /tmp/base/mpm .gpu/bin/mpm "--scene bench-655k" "--scene bench-655k --scatter fixed-point" "--scene dam-break" "--scene dam-break --scatter fixed-point" 2>&1 | tail -8 | tee $R/bench-ab.md
echo "=== fixed-point particles, base vs new"
bash scripts/ply-identity.sh /tmp/base/mpm .gpu/bin/mpm /tmp/ply --keep > /dev/null 2>&1
for s in dam-break fountain tap; do python3 scripts/ply-same-particles.py /tmp/ply/$s-a /tmp/ply/$s-b > $R/ply-$s.txt; echo "$s exit $?: $(tail -1 $R/ply-$s.txt)"; done
echo "=== tests"
bash .gpu/run bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --out $R/tests --timeout 300 > $R/tests.txt 2>&1; echo "tests exit $?"; grep -E "passed|FAIL|panicked" $R/tests.txt | tail -14
echo "=== presets"
for s in honey:300 mud-dam-break:180 oil-on-water:300; do n=${s%%:*}; f=${s##*:}
  .gpu/bin/mpm run --scene $n --frames $f > $R/run-$n.txt 2>&1; echo "$n: exit $? $(grep -c '^frame' $R/run-$n.txt) frames; $(tail -1 $R/run-$n.txt)"; grep "^frame" $R/run-$n.txt | tail -1 | cut -c1-200
  bash .gpu/run .gpu/bin/mpm render --scene $n --frames $f --size 960x540 --out /tmp/render-$n > $R/render-$n.txt 2>&1; echo "render $n exit $?"; tail -2 $R/render-$n.txt
  mkdir -p $R/pictures/$n; for k in 30 60 120 180 240 300; do ls /tmp/render-$n/*$(printf %06d $k)* 2>/dev/null | head -1 | xargs -r -I{} cp {} $R/pictures/$n/; done
done
ls /tmp/render-honey | head -3
tar czf $OUT/results.tgz -C $OUT r && rm -rf $R
ls -la $OUT
