#!/usr/bin/env bash
# Session 29 call 6: where pbmpm-1m's substep goes once the liquid has spread (10 s in, where its frame
# costs 16.7 ms averaged over 18 s): every kernel's duration by Nsight Compute at the GPU's own clocks
# over about two frames, launched one by one (MPM_CUDA_GRAPHS=0) so the launches are counted plainly.
set -u
tar -xJf .gpu-pack/pack.tar.xz
L=/tmp/logs; rm -rf $L; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
for at in 2000:early 100000:late; do skip=${at%%:*} name=${at##*:}
  MPM_CUDA_GRAPHS=0 timeout 280 bash scripts/ncu-kernels.sh pbmpm-1m-$name "regex:.*" --skip $skip --count 400 --metrics gpu__time_duration.sum --out $L --timeout 270 -- run --backend cuda --scene pbmpm-1m --frames 800 > $L/ncu-$name.txt 2>&1
  echo "== ncu $name (skip $skip) rc $?"
  python3 - $L/pbmpm-1m-$name-metrics.csv <<'PY'
import csv, sys, collections
rows = [r for r in csv.reader(l for l in open(sys.argv[1]) if not l.startswith("=="))]
head = rows[0]; k = head.index("Kernel Name"); v = head.index("Metric Value"); u = head.index("Metric Unit")
tot = collections.defaultdict(float); n = collections.Counter()
for r in rows[1:]:
    if len(r) <= v or not r[v].replace(",", "").replace(".", "").isdigit(): continue
    x = float(r[v].replace(",", "")); x = x / 1000 if r[u] == "nsecond" else (x * 1000 if r[u] == "msecond" else x)
    name = r[k].split("(")[0]; tot[name] += x; n[name] += 1
subs = n.get("pbmpm_integrate", 1)
print(f"   {sum(n.values())} launches, {subs} substeps; us per substep by kernel:")
for name, t in sorted(tot.items(), key=lambda kv: -kv[1]):
    print(f"   {name:40s} {n[name]:4d} launches  {t / subs:9.1f} us a substep  {t / n[name]:8.1f} us each")
print(f"   total {sum(tot.values()) / subs:.1f} us a substep")
PY
done
tar -czf $OUT/logs.tgz -C /tmp logs
