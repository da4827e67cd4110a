#!/usr/bin/env bash
# Call 5: staged run sums with the open sums carried by a segmented scan in runs of more than 9 lanes
# (gen; glb5 at 5 blocks per SM) against main, uni (call 3's, embedded) and main at 5 blocks
# (mlb5); then the whole suite with gen's one_pass.
export NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
B=$PWD/.gpu/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s16
for sc in "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $sc == *16777216* ]] && steps="300 --warmup 100"
  for r in 1 2; do for v in main uni gen glb5 mlb5; do
    m=$B/mpm; d=$PWD/.gpu/ptx-$v
    case $v in main|mlb5) m=$B/mpm-old;; uni) d=/nonexistent;; esac
    echo "== $v $sc"; MPM_PTX_DIR=$d timeout 90 $m bench $sc --steps $steps 2>&1 | grep -E "one_pass \(|total|panic|rror:"
done; done; done > $OUT/s16/bench.txt 2>&1
python3 - $OUT/s16/bench.txt <<'PY' | tee $OUT/s16/summary.txt
import sys,collections
cur=None; res=collections.defaultdict(list); op=collections.defaultdict(list)
for line in open(sys.argv[1]):
    if line.startswith('=='): cur=line[3:].strip(); continue
    c=[x.strip() for x in line.split('|')]
    if len(c)>2 and 'total' in c[1]: res[cur].append(float(c[2]))
    elif len(c)>2 and c[1].startswith('one_pass'): op[cur].append(float(c[2]))
for k in res: print(f"{k:50s} total {res[k]}  one_pass {op[k]}")
PY
export MPM_BIN=$B/mpm MPM_PTX_DIR=$PWD/.gpu/ptx-gen
timeout 300 bash .gpu/run .gpu/tests/all > $OUT/s16/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s16/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s16/tests.log | head -20
