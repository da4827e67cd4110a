#!/usr/bin/env bash
# Call 4: one_pass's float path as warps taking 32-particle slices in turn (no barrier), against main
# at 016e66d (mpm-old: a block per chunk, dead warps skipped); the new one's grid at the default
# (32 blocks per SM), 6 (resident: persistent) and 12 blocks per SM.
export NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm; O=$PWD/.gpu/bin/mpm-old
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s4
run_v() { local v=$1; shift; local bin=$M
  case $v in old) bin=$O;; esac
  case $v in new6) export MPM_ONE_PASS_BLOCKS_PER_SM=6;; new12) export MPM_ONE_PASS_BLOCKS_PER_SM=12;; *) unset MPM_ONE_PASS_BLOCKS_PER_SM;; esac
  timeout 90 $bin "$@"; }
for sc in "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--particles 16777216 --grid 256"; do
  steps=2000; vs="old new new6 new12"; [[ $sc == *16777216* ]] && steps="300 --warmup 100"
  [[ $sc == *fixed* ]] && vs="old new"
  for r in 1 2; do for v in $vs; do
    echo "== $v $sc"; run_v $v bench $sc --steps $steps 2>&1 | grep -E "one_pass \(|total|panic"
done; done; done > $OUT/s4/bench.txt 2>&1
python3 - $OUT/s4/bench.txt <<'PY'
import sys,collections
cur=None; res=collections.defaultdict(list); op=collections.defaultdict(list)
for line in open(sys.argv[1]):
    if line.startswith('=='): cur=line[3:].strip(); continue
    c=[x.strip() for x in line.split('|')]
    if len(c)>2 and 'total' in c[1]: res[cur].append(float(c[2]))
    elif len(c)>2 and c[1].startswith('one_pass'): op[cur].append(float(c[2]))
for k in res: print(f"{k:50s} total {res[k]}  one_pass {op[k]}")
PY
