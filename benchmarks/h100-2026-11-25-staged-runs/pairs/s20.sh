#!/usr/bin/env bash
# Call 9: one_pass_float with two particles a thread (pairs: blocks of 64 threads, 8 per SM, 128
# registers) against HEAD 6ef501f (mpm-head: one particle a thread, 5 blocks of 128 per SM); the
# fixed-point PLY bytes (its code is shared); memcheck of the float scatter; the whole suite.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
B=$PWD/.gpu/bin M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s20
for sc in "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $sc == *16777216* ]] && steps="300 --warmup 100"
  for r in 1 2; do for v in head pairs; do
    m=$M; [ $v = head ] && m=$B/mpm-head
    echo "== $v $sc"; timeout 90 $m bench $sc --steps $steps 2>&1 | grep -E "one_pass|total|panic|rror:"
done; done; done > $OUT/s20/bench.txt 2>&1
python3 - $OUT/s20/bench.txt <<'PY' | tee $OUT/s20/summary.txt
import sys,collections
cur=None; res=collections.defaultdict(list); op=collections.defaultdict(list)
for line in open(sys.argv[1]):
    if line.startswith('=='): cur=line[3:].strip(); continue
    c=[x.strip() for x in line.split('|')]
    if len(c)>2 and 'total' in c[1]: res[cur].append(float(c[2]))
    elif len(c)>2 and c[1].startswith('one_pass'): op[cur].append(float(c[2]))
for k in res: print(f"{k:50s} total {res[k]}  one_pass {op[k]}")
PY
(cd /tmp; timeout 60 $B/mpm-head run --backend cuda --scene dam-break --scatter fixed-point --frames 60 --export s20-head > /dev/null 2>&1 || echo "head run failed"
 timeout 60 $M run --backend cuda --scene dam-break --scatter fixed-point --frames 60 --export s20-pairs > /dev/null 2>&1 || echo "pairs run failed"
 diff -rq s20-head s20-pairs > /dev/null && echo "dam-break fixed point: $(ls s20-pairs | wc -l) files byte-identical head vs pairs" || echo "DIFFER") | tee $OUT/s20/ply.txt
timeout 60 compute-sanitizer --tool memcheck --error-exitcode 9 $M run --backend cuda --scene $PWD/.gpu/scenes/dam-break-crossing.toml --frames 2 --scatter float > /tmp/san.log 2>&1; echo "memcheck crossing float: rc=$? $(grep -E 'ERROR SUMMARY' /tmp/san.log)" | tee $OUT/s20/sanitize.txt
timeout 300 bash .gpu/run .gpu/tests/all > $OUT/s20/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s20/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s20/tests.log | head -20
