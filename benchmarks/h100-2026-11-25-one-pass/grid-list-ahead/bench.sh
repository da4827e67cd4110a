#!/usr/bin/env bash
# Call 8: grid_update_blocks reading the next list entry a block ahead (pf: 78 registers; pf14: the
# same held to 72 by __launch_bounds__(64, 14)) against main's (gh, 72), through MPM_PTX_DIR.
export NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s8
for sc in "--particles 16777216 --grid 256" "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point"; do
  steps=2000; [[ $sc == *16777216* ]] && steps="300 --warmup 100"
  for r in 1 2; do for v in gh pf pf14; do
    echo "== $v $sc"; MPM_PTX_DIR=$PWD/.gpu/ptx-$v timeout 90 $M bench $sc --steps $steps 2>&1 | grep -E "grid_update_blocks|total|panic"
done; done; done > $OUT/s8/bench.txt 2>&1
python3 - $OUT/s8/bench.txt <<'PY'
import sys,collections
cur=None; res=collections.defaultdict(list); op=collections.defaultdict(list)
for line in open(sys.argv[1]):
    if line.startswith('=='): cur=line[3:].strip(); continue
    c=[x.strip() for x in line.split('|')]
    if len(c)>2 and 'total' in c[1]: res[cur].append(float(c[2]))
    elif len(c)>2 and c[1].startswith('grid_update_blocks'): op[cur].append(float(c[2]))
for k in res: print(f"{k:50s} total {res[k]}  grid {op[k]}")
PY
