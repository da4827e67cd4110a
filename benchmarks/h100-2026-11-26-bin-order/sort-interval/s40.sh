#!/usr/bin/env bash
# SORT_INTERVAL 4 and 16 (mpm-sort4, mpm-sort16) against 8 (baa8369), now that each binning gathers the particles.
export NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s40
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
for k in 4 16; do
  OUT=$OUT/s40/k$k bash scripts/bench-ab.sh $M $PWD/.gpu/bin/mpm-sort$k "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" > /dev/null 2>&1; echo "== SORT_INTERVAL $k (after) against 8 (before)"; means $OUT/s40/k$k
  STEPS=300 WARMUP=100 OUT=$OUT/s40/k$k-16m bash scripts/bench-ab.sh $M $PWD/.gpu/bin/mpm-sort$k "--particles 16777216 --grid 256" > /dev/null 2>&1; means $OUT/s40/k$k-16m | tail -1
done | tee $OUT/s40/sort-interval.txt
rm -rf $OUT/s40/k*
