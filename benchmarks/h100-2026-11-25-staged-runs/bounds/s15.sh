#!/usr/bin/env bash
# Call 4: main's one_pass compiled for 5 and 4 blocks per SM (96 and 128 registers) against main's
# 6 (80); ncu stall sampling of the staged run sums (uni, embedded) at the dam break.
export NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
B=$PWD/.gpu/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s15
for sc in "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $sc == *16777216* ]] && steps="300 --warmup 100"
  for r in 1 2; do for v in main mlb5 mlb4; do
    echo "== $v $sc"; MPM_PTX_DIR=$PWD/.gpu/ptx-$v timeout 90 $B/mpm-old bench $sc --steps $steps 2>&1 | grep -E "one_pass \(|total|panic|rror:"
done; done; done > $OUT/s15/bench.txt 2>&1
python3 - $OUT/s15/bench.txt <<'PY' | tee $OUT/s15/summary.txt
import sys,collections
cur=None; res=collections.defaultdict(list); op=collections.defaultdict(list)
for line in open(sys.argv[1]):
    if line.startswith('=='): cur=line[3:].strip(); continue
    c=[x.strip() for x in line.split('|')]
    if len(c)>2 and 'total' in c[1]: res[cur].append(float(c[2]))
    elif len(c)>2 and c[1].startswith('one_pass'): op[cur].append(float(c[2]))
for k in res: print(f"{k:50s} total {res[k]}  one_pass {op[k]}")
PY
timeout 90 ncu --clock-control none --set full --import-source yes -k regex:one_pass --launch-skip 30 --launch-count 1 -o $OUT/s15/uni-dam $B/mpm bench --scene dam-break --steps 40 --warmup 10 > $OUT/s15/ncu.log 2>&1; echo "ncu rc $?"
ncu -i $OUT/s15/uni-dam.ncu-rep --page source --csv --print-source sass > $OUT/s15/uni-sass.csv 2>&1
ncu -i $OUT/s15/uni-dam.ncu-rep --page details --csv > $OUT/s15/uni-details.csv 2>&1; rm -f $OUT/s15/uni-dam.ncu-rep
xz -T4 $OUT/s15/uni-sass.csv; ls -la $OUT/s15
