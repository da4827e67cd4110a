#!/usr/bin/env bash
# Call 10: larger bin chunks (fewer chunks per SM wanted: 48 is main's; 24, 12) for both scatters.
export NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s10
for sc in "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break" "--scene bench-655k" "--scene dam-break-1m --scatter fixed-point"; do
  for r in 1 2; do for v in 48 24 12; do
    export MPM_CHUNKS_PER_SM=$v
    echo "== c$v $sc"; timeout 90 $M bench $sc --steps 2000 2>&1 | grep -E "one_pass \(|total|panic|rror:"
done; done; done > $OUT/s10/bench.txt 2>&1
python3 - $OUT/s10/bench.txt <<'PY'
import sys,collections
cur=None; res=collections.defaultdict(list); op=collections.defaultdict(list)
for line in open(sys.argv[1]):
    if line.startswith('=='): cur=line[3:].strip(); continue
    c=[x.strip() for x in line.split('|')]
    if len(c)>2 and 'total' in c[1]: res[cur].append(float(c[2]))
    elif len(c)>2 and c[1].startswith('one_pass'): op[cur].append(float(c[2]))
for k in res: print(f"{k:50s} total {res[k]}  one_pass {op[k]}")
PY
