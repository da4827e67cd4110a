#!/usr/bin/env python3
"""Per-kernel duration from `ncu --csv --page raw --metrics gpu__time_duration.sum`: launches, mean
and total microseconds, by kernel name."""
import csv, sys, collections
rows = list(csv.reader(open(sys.argv[1])))
head = next(i for i, r in enumerate(rows) if "Kernel Name" in r)
cols = rows[head]
k, t = cols.index("Kernel Name"), cols.index("gpu__time_duration.sum")
units = rows[head + 1][t] if not rows[head + 1][0].isdigit() else "ns"
sums = collections.defaultdict(list)
for r in rows[head + 1:]:
    if len(r) <= t or not r[t].replace(".", "").replace(",", "").isdigit():
        continue
    sums[r[k].split("(")[0]].append(float(r[t].replace(",", "")))
scale = {"ns": 1e-3, "usecond": 1.0, "us": 1.0, "msecond": 1e3, "ms": 1e3, "nsecond": 1e-3}.get(units, 1e-3)
print(f"(units {units})")
for name, v in sorted(sums.items(), key=lambda kv: -sum(kv[1])):
    print(f"{name[:40]:<40} {len(v):>6} launches, mean {sum(v)/len(v)*scale:>10.1f} us, total {sum(v)*scale:>10.1f} us")
