"""Sums an ncu raw page (scripts/ncu-kernels.sh --metrics gpu__time_duration.sum, its CSV) by kernel:
launches, microseconds per substep (the substeps counted by pbmpm_integrate's launches) and per launch.
Usage: python3 ncu-sum.py METRICS_CSV"""
import csv, sys, collections
lines = open(sys.argv[1]).read().split("\n")
start = next(i for i, l in enumerate(lines) if '"Kernel Name"' in l)
rows = list(csv.reader(l for l in lines[start:] if l and not l.startswith("==") and not l.startswith("frame")))
head = rows[0]; k = head.index("Kernel Name"); v = head.index("gpu__time_duration.sum")
units = rows[1][v]
scale = {"nsecond": 1e-3, "ns": 1e-3, "usecond": 1.0, "us": 1.0, "msecond": 1e3, "ms": 1e3}[units]
tot = collections.defaultdict(float); n = collections.Counter()
for r in rows[2:]:
    if len(r) <= v: continue
    try: x = float(r[v].replace(",", "")) * scale
    except ValueError: continue
    name = r[k].split("(")[0]; tot[name] += x; n[name] += 1
subs = n.get("pbmpm_integrate", 1)
print(f"{sum(n.values())} launches, {subs} substeps; us a substep by kernel:")
for name, t in sorted(tot.items(), key=lambda kv: -kv[1]):
    print(f"  {name:36s} {n[name]:4d} launches {t / subs:8.1f} us a substep {t / n[name]:8.1f} us each")
print(f"  total {sum(tot.values()) / subs:.1f} us a substep")
