#!/usr/bin/env bash
# Call 1 (2026-11-27, materials): water-only identity and speed against 12e54ac, the materials' rows,
# the GPU tests with the new tests/gpu_materials.rs.
set -u
mkdir -p .gpu/bin /tmp/base .gpu/tests
xz -dc .gpu-pack1/mpm.xz > .gpu/bin/mpm && chmod +x .gpu/bin/mpm
xz -dc .gpu-pack1/mpm-base.xz > /tmp/base/mpm && chmod +x /tmp/base/mpm
tar xJf .gpu-pack1/tests.tar.xz -C .gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/device.txt
echo "=== warm the JIT caches"; for b in /tmp/base/mpm .gpu/bin/mpm; do $b bench --scene bench-65k --steps 20 --warmup 5 > /dev/null 2>&1; done
echo "=== ply identity, fixed point, base vs new"; s=$(date +%s)
bash scripts/ply-identity.sh /tmp/base/mpm .gpu/bin/mpm $OUT/ply > /dev/null 2>&1; echo "ply exit $? in $(( $(date +%s) - s )) s"
grep -v "identical$" $OUT/ply/summary.txt | tail -6; grep -c "identical$" $OUT/ply/summary.txt
bash scripts/ply-identity.sh /tmp/base/mpm .gpu/bin/mpm $OUT/ply-binned --scenes "dam-break:60" -- --pipeline binned > /dev/null 2>&1; echo "ply binned exit $?"
grep -v "identical$" $OUT/ply-binned/summary.txt | tail -3
echo "=== bench a/b"; s=$(date +%s)
OUT=$OUT/bench-ab RUNS=2 bash scripts/bench-ab.sh /tmp/base/mpm .gpu/bin/mpm "--scene bench-655k" "--scene dam-break" "--scene bench-655k --pipeline binned" "--scene bench-655k --scatter fixed-point" "--scene bench-655k --pipeline report" 2>&1 | tail -16
echo "bench exit in $(( $(date +%s) - s )) s"
echo "=== materials rows"; mkdir -p $OUT/rows
for s in bench-655k benches/scenes/bench-655k-power-law.toml benches/scenes/bench-655k-carreau-yasuda.toml benches/scenes/bench-655k-herschel-bulkley.toml benches/scenes/bench-655k-two-liquids.toml; do
  n=$(basename $s .toml)
  for p in fused binned; do
    .gpu/bin/mpm bench --scene $s --pipeline $p --steps 2000 --warmup 200 --json $OUT/rows/$n-$p.json > $OUT/rows/$n-$p.log 2>&1 || echo "FAILED $n $p"
    echo "$n $p: $(grep -iE "median|total" $OUT/rows/$n-$p.log | head -2 | tr '\n' ' ')"
  done
done
echo "=== tests"; s=$(date +%s)
bash .gpu/run bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --out $OUT/tests --timeout 400 > $OUT/tests.txt 2>&1; echo "tests exit $? in $(( $(date +%s) - s )) s"
tail -40 $OUT/tests.txt
