#!/usr/bin/env bash
# The fused pipeline binning every 16 substeps (working tree, mpm) against every 8 (baa8369): means and medians,
# fixed-point PLY bytes against 06f9cc2, then the whole suite.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm B=$PWD/.gpu/bin/mpm-baa8369 H=$PWD/.gpu/bin/mpm-head
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s41
means() { python3 - "$1" <<'PY'
import json, sys, glob, re, collections
rows = collections.defaultdict(lambda: collections.defaultdict(list))
for f in glob.glob(sys.argv[1] + "/*.json"):
    c, side = re.search(r"case(\d+)-(before|after)-\d+\.json", f).groups()
    s = json.load(open(f))["phases"][0]
    rows[(int(c), s["scene"], s["scatter"])][side].append((s["total"]["mean_ms"], s["total"]["median_ms"], {r["phase"]: r["mean_ms"] for r in s["rows"]}))
print("| case | before mean / median | after mean / median | mean change | sort mean, before -> after | one_pass mean |")
print("|---|---:|---:|---:|---:|---:|")
for (c, scene, scatter), sides in sorted(rows.items()):
    b, a = sides["before"], sides["after"]
    avg = lambda xs, i: sum(x[i] for x in xs) / len(xs)
    ph = lambda xs, p: sum(x[2][p] for x in xs) / len(xs)
    print(f"| {scene} {scatter} | {avg(b,0):.4f} / {avg(b,1):.4f} | {avg(a,0):.4f} / {avg(a,1):.4f} | {100*(avg(a,0)/avg(b,0)-1):+.1f} % | {ph(b,'sort'):.4f} -> {ph(a,'sort'):.4f} | {ph(b,'g2p'):.4f} -> {ph(a,'g2p'):.4f} |")
PY
}
OUT=$OUT/s41/ab bash scripts/bench-ab.sh $B $M "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene fountain" > /dev/null 2>&1; means $OUT/s41/ab | tee $OUT/s41/means.txt
STEPS=300 WARMUP=100 OUT=$OUT/s41/ab16 bash scripts/bench-ab.sh $B $M "--particles 16777216 --grid 256" > /dev/null 2>&1; means $OUT/s41/ab16 | tail -1 | tee -a $OUT/s41/means.txt
rm -rf $OUT/s41/ab $OUT/s41/ab16
(cd /tmp; for sc in dam-break fountain; do
  timeout 90 $H run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export h-$sc > /dev/null 2>&1 || echo "head $sc failed"
  timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export n-$sc > /dev/null 2>&1 || echo "new $sc failed"
  diff -rq h-$sc n-$sc > /dev/null && echo "$sc fixed point: $(ls n-$sc | wc -l) PLY files byte-identical, 06f9cc2 vs binning every 16" || echo "$sc DIFFER: $(diff -rq h-$sc n-$sc | wc -l)"
done) | tee $OUT/s41/identity.txt
$M bench --scene dam-break --steps 200 2>&1 | grep -i "rebin" | tee -a $OUT/s41/identity.txt
timeout 330 bash .gpu/run .gpu/tests/all > $OUT/s41/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s41/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run|tile misses" $OUT/s41/tests.log | head -20
