#!/usr/bin/env bash
# Call 2: staged run sums with the leftover nodes summed by warp runs (hyb, and hlb5 at 5 blocks per
# SM), against main; main's kernel launched with the staged build's 18 KB of shared memory (mshm:
# what the shared memory alone costs the gather's L1).
export NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
B=$PWD/.gpu/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s13
for sc in "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $sc == *16777216* ]] && steps="300 --warmup 100"
  for r in 1 2; do for v in main hyb hlb5 mshm; do
    m=$B/mpm; d=$PWD/.gpu/ptx-$v; [ $v = mshm ] && d=$PWD/.gpu/ptx-main
    if [ $v = main ]; then m=$B/mpm-main; d=$PWD/.gpu/ptx-main; fi
    echo "== $v $sc"; MPM_PTX_DIR=$d timeout 90 $m bench $sc --steps $steps 2>&1 | grep -E "one_pass \(|total|panic|rror:"
done; done; done > $OUT/s13/bench.txt 2>&1
python3 - $OUT/s13/bench.txt <<'PY' | tee $OUT/s13/summary.txt
import sys,collections
cur=None; res=collections.defaultdict(list); op=collections.defaultdict(list)
for line in open(sys.argv[1]):
    if line.startswith('=='): cur=line[3:].strip(); continue
    c=[x.strip() for x in line.split('|')]
    if len(c)>2 and 'total' in c[1]: res[cur].append(float(c[2]))
    elif len(c)>2 and c[1].startswith('one_pass'): op[cur].append(float(c[2]))
for k in res: print(f"{k:50s} total {res[k]}  one_pass {op[k]}")
PY
