#!/usr/bin/env bash
# Call 3: staged run sums with every lane summing 9 of its run's sums (uni; ulb5 at 5 blocks per SM,
# u9 with the share's loop unrolled whole) against main; then frames and the whole suite with uni.
export NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
B=$PWD/.gpu/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s14
for sc in "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $sc == *16777216* ]] && steps="300 --warmup 100"
  for r in 1 2; do for v in main uni ulb5 u9; do
    m=$B/mpm; d=$PWD/.gpu/ptx-$v
    [ $v = main ] && m=$B/mpm-main
    [ $v = uni ] && d=/nonexistent
    echo "== $v $sc"; MPM_PTX_DIR=$d timeout 90 $m bench $sc --steps $steps 2>&1 | grep -E "one_pass \(|total|panic|rror:"
done; done; done > $OUT/s14/bench.txt 2>&1
python3 - $OUT/s14/bench.txt <<'PY' | tee $OUT/s14/summary.txt
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
(cd /tmp; for v in main uni main uni; do m=$B/mpm; [ $v = main ] && m=$B/mpm-main
  echo "$v $(timeout 60 $m render --scene dam-break --frames 90 --size 960x540 --no-images 2>&1 | grep 'frames via')"; done) | tee $OUT/s14/render.txt
timeout 300 bash .gpu/run .gpu/tests/all > $OUT/s14/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s14/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s14/tests.log | head -20
