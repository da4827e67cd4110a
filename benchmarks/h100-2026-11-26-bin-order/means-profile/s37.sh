#!/usr/bin/env bash
# 3efcdf4 (bin order): means and medians against 06f9cc2; ncu of one_pass at the dam break; one_pass_float at 6 and 4 blocks per SM.
export NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm H=$PWD/.gpu/bin/mpm-head G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s37
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
OUT=$OUT/s37/means bash scripts/bench-ab.sh $H $M "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" > /dev/null 2>&1; means $OUT/s37/means | tee $OUT/s37/means.txt
STEPS=300 WARMUP=100 OUT=$OUT/s37/means16 bash scripts/bench-ab.sh $H $M "--particles 16777216 --grid 256" > /dev/null 2>&1; means $OUT/s37/means16 | tail -1 | tee -a $OUT/s37/means.txt
for b in 6 4; do OUT=$OUT/s37/fb$b bash scripts/bench-ab.sh $M $M@$G/ptx-fb$b "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" 2>&1 | grep "^| \`" | sed "s/^/fb$b /" | tee -a $OUT/s37/blocks.txt; done
rm -rf $OUT/s37/*/*.log $OUT/s37/means $OUT/s37/means16 $OUT/s37/fb6 $OUT/s37/fb4
timeout 120 ncu --clock-control none --set full --import-source yes -k regex:one_pass --launch-skip 30 --launch-count 1 -o /tmp/op $M bench --scene dam-break --steps 40 --warmup 10 > $OUT/s37/ncu.log 2>&1; echo "ncu rc $?"
ncu -i /tmp/op.ncu-rep --page source --csv --print-source sass > /tmp/op-sass.csv 2>&1; python3 scripts/ncu-stalls.py /tmp/op-sass.csv > $OUT/s37/ncu-one_pass-stalls.txt 2>&1; head -30 $OUT/s37/ncu-one_pass-stalls.txt
ncu -i /tmp/op.ncu-rep --page details --csv > /tmp/op-details.csv 2>&1; grep -E '"(Duration|Achieved Occupancy|Memory Throughput|Compute \(SM\) Throughput|Registers Per Thread|L1/TEX Hit Rate|L2 Hit Rate|DRAM Throughput)"' /tmp/op-details.csv | cut -d, -f12- | tee $OUT/s37/ncu-details.txt
