#!/usr/bin/env bash
# Call 5: where the persistent grid's gain at small chunks comes from. mpm-old = main at 016e66d;
# mpm-e = the same with a plain read before each warp's atomicMax of the extremes, and
# MPM_ONE_PASS_BLOCKS_PER_SM; h6 = mpm-e's binary with main's one_pass PTX at 6 blocks per SM.
export NCCL_NVLS_ENABLE=0
O=$PWD/.gpu/bin/mpm-old; E=$PWD/.gpu/bin/mpm-e
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s5
run_v() { local v=$1; shift; local bin=$E d=/nonexistent
  case $v in old) bin=$O;; h6) d=$PWD/.gpu/ptx-h;; esac
  case $v in e6|h6) export MPM_ONE_PASS_BLOCKS_PER_SM=6;; e12) export MPM_ONE_PASS_BLOCKS_PER_SM=12;; *) unset MPM_ONE_PASS_BLOCKS_PER_SM;; esac
  MPM_PTX_DIR=$d timeout 90 $bin "$@"; }
for sc in "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--particles 16777216 --grid 256"; do
  steps=2000; vs="old e e6 h6 e12"; [[ $sc == *16777216* ]] && steps="300 --warmup 100"
  for r in 1 2; do for v in $vs; do
    echo "== $v $sc"; run_v $v bench $sc --steps $steps 2>&1 | grep -E "one_pass \(|total|panic"
done; done; done > $OUT/s5/bench.txt 2>&1
python3 - $OUT/s5/bench.txt <<'PY'
import sys,collections
cur=None; res=collections.defaultdict(list); op=collections.defaultdict(list)
for line in open(sys.argv[1]):
    if line.startswith('=='): cur=line[3:].strip(); continue
    c=[x.strip() for x in line.split('|')]
    if len(c)>2 and 'total' in c[1]: res[cur].append(float(c[2]))
    elif len(c)>2 and c[1].startswith('one_pass'): op[cur].append(float(c[2]))
for k in res: print(f"{k:50s} total {res[k]}  one_pass {op[k]}")
PY
