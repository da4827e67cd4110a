#!/usr/bin/env bash
# The session's end (9f5ebf0, mpm) against its start (06f9cc2, mpm-head): substeps (means and medians), headless frames.
export NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm H=$PWD/.gpu/bin/mpm-head
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s42
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
OUT=$OUT/s42/ab bash scripts/bench-ab.sh $H $M "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" > /dev/null 2>&1; means $OUT/s42/ab | tee $OUT/s42/means.txt
STEPS=300 WARMUP=100 OUT=$OUT/s42/ab16 bash scripts/bench-ab.sh $H $M "--particles 16777216 --grid 256" > /dev/null 2>&1; means $OUT/s42/ab16 | tail -1 | tee -a $OUT/s42/means.txt
rm -rf $OUT/s42/ab $OUT/s42/ab16
for sc in "dam-break --size 960x540" "dam-break-1m --size 960x540" "dam-break --size 1920x1080"; do for v in head new head new; do b=$M; [ $v = head ] && b=$H
  echo "== $v render $sc"; timeout 60 $b render --scene $sc --frames 90 --no-images 2>&1 | grep -E "frames via|GPU ms per pass"; done; done | tee $OUT/s42/render.txt
