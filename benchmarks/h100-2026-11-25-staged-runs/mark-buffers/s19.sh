#!/usr/bin/env bash
# Call 8: one_pass_float with two alternating buffers of node-block marks, one barrier per bin chunk
# instead of three (marks2, embedded) against HEAD cfb9946 (head: its one_pass PTX); sanitizers on
# the float scatter; the whole suite.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s19
for sc in "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $sc == *16777216* ]] && steps="300 --warmup 100"
  for r in 1 2; do for v in head marks2; do
    d=/nonexistent; [ $v = head ] && d=$PWD/.gpu/ptx-head
    echo "== $v $sc"; MPM_PTX_DIR=$d timeout 90 $M bench $sc --steps $steps 2>&1 | grep -E "one_pass|total|panic|rror:"
done; done; done > $OUT/s19/bench.txt 2>&1
python3 - $OUT/s19/bench.txt <<'PY' | tee $OUT/s19/summary.txt
import sys,collections
cur=None; res=collections.defaultdict(list); op=collections.defaultdict(list)
for line in open(sys.argv[1]):
    if line.startswith('=='): cur=line[3:].strip(); continue
    c=[x.strip() for x in line.split('|')]
    if len(c)>2 and 'total' in c[1]: res[cur].append(float(c[2]))
    elif len(c)>2 and c[1].startswith('one_pass'): op[cur].append(float(c[2]))
for k in res: print(f"{k:50s} total {res[k]}  one_pass {op[k]}")
PY
sc=$PWD/.gpu/scenes/dam-break-crossing.toml
for tool in memcheck racecheck; do timeout 60 compute-sanitizer --tool $tool --error-exitcode 9 $M run --backend cuda --scene $sc --frames 2 --scatter float > /tmp/san.log 2>&1; echo "$tool crossing float: rc=$? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/san.log)"; done | tee $OUT/s19/sanitize.txt
timeout 300 bash .gpu/run .gpu/tests/all > $OUT/s19/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s19/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s19/tests.log | head -20
