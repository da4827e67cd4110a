#!/usr/bin/env bash
# Call 9: one_pass in CUDA blocks of 64 threads (2 warps: less waiting at a chunk's end for the block's
# slowest warp; __launch_bounds__(64, 12), the same 80 registers) against main's 128.
export NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s9
for sc in "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $sc == *16777216* ]] && steps="300 --warmup 100"
  for r in 1 2; do for v in head t64; do
    if [ $v = t64 ]; then export MPM_ONE_PASS_THREADS=64 MPM_PTX_DIR=$PWD/.gpu/ptx-t64; else unset MPM_ONE_PASS_THREADS MPM_PTX_DIR; fi
    echo "== $v $sc"; timeout 90 $M bench $sc --steps $steps 2>&1 | grep -E "one_pass \(|total|panic|rror:"
done; done; done > $OUT/s9/bench.txt 2>&1
python3 - $OUT/s9/bench.txt <<'PY'
import sys,collections
cur=None; res=collections.defaultdict(list); op=collections.defaultdict(list)
for line in open(sys.argv[1]):
    if line.startswith('=='): cur=line[3:].strip(); continue
    c=[x.strip() for x in line.split('|')]
    if len(c)>2 and 'total' in c[1]: res[cur].append(float(c[2]))
    elif len(c)>2 and c[1].startswith('one_pass'): op[cur].append(float(c[2]))
for k in res: print(f"{k:50s} total {res[k]}  one_pass {op[k]}")
PY
grep -iE "panic|error:" $OUT/s9/bench.txt | head -3
