#!/usr/bin/env bash
# Call 1 (2026-11-25, fourth session): one_pass's float scatter with staged run sums (shared memory)
# against main (c78c3a5: warp_run_sum shuffles); the same at 5 blocks per SM; then the whole suite.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
B=$PWD/.gpu/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s12
for sc in "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $sc == *16777216* ]] && steps="300 --warmup 100"
  for r in 1 2; do for v in main staged lb5; do
    m=$B/mpm; [ $v = main ] && m=$B/mpm-main; [ $v = lb5 ] && m=$B/mpm-lb5
    echo "== $v $sc"; timeout 90 $m bench $sc --steps $steps 2>&1 | grep -E "one_pass \(|total|panic|rror:"
done; done; done > $OUT/s12/bench.txt 2>&1
python3 - $OUT/s12/bench.txt <<'PY' | tee $OUT/s12/summary.txt
import sys,collections
cur=None; res=collections.defaultdict(list); op=collections.defaultdict(list)
for line in open(sys.argv[1]):
    if line.startswith('=='): cur=line[3:].strip(); continue
    c=[x.strip() for x in line.split('|')]
    if len(c)>2 and 'total' in c[1]: res[cur].append(float(c[2]))
    elif len(c)>2 and c[1].startswith('one_pass'): op[cur].append(float(c[2]))
for k in res: print(f"{k:50s} total {res[k]}  one_pass {op[k]}")
PY
bash .gpu/run true > /dev/null 2>&1
(cd /tmp; for v in main staged main staged; do m=$B/mpm; [ $v = main ] && m=$B/mpm-main
  echo "$v $(timeout 60 $m render --scene dam-break --frames 90 --size 960x540 --no-images 2>&1 | tail -1)"; done) | tee $OUT/s12/render.txt
timeout 300 bash .gpu/run .gpu/tests/all > $OUT/s12/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s12/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s12/tests.log | head -20
