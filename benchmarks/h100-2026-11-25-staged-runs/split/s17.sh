#!/usr/bin/env bash
# Call 6: one_pass split into one_pass_float (5 blocks per SM) and one_pass_fixed (6), against main
# (c78c3a5: mpm-old with main's PTX). Bench, the whole suite, PLY bytes of the fixed-point dam break
# and fountain against main, headless frames, sanitizers on both entry points.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
B=$PWD/.gpu/bin M=$PWD/.gpu/bin/mpm P=$PWD/.gpu/ptx-main
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s17
for sc in "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $sc == *16777216* ]] && steps="300 --warmup 100"
  for r in 1 2; do for v in main split; do
    if [ $v = main ]; then m=$B/mpm-old; d=$P; else m=$M; d=/nonexistent; fi
    echo "== $v $sc"; MPM_PTX_DIR=$d timeout 90 $m bench $sc --steps $steps 2>&1 | grep -E "one_pass|total|panic|rror:"
done; done; done > $OUT/s17/bench.txt 2>&1
python3 - $OUT/s17/bench.txt <<'PY' | tee $OUT/s17/summary.txt
import sys,collections
cur=None; res=collections.defaultdict(list); op=collections.defaultdict(list)
for line in open(sys.argv[1]):
    if line.startswith('=='): cur=line[3:].strip(); continue
    c=[x.strip() for x in line.split('|')]
    if len(c)>2 and 'total' in c[1]: res[cur].append(float(c[2]))
    elif len(c)>2 and c[1].startswith('one_pass'): op[cur].append(float(c[2]))
for k in res: print(f"{k:50s} total {res[k]}  one_pass {op[k]}")
PY
(cd /tmp
for sc in dam-break fountain; do
  MPM_PTX_DIR=$P timeout 60 $B/mpm-old run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export s17-main-$sc > /dev/null 2>&1 || echo "run main $sc failed"
  timeout 60 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export s17-split-$sc > /dev/null 2>&1 || echo "run split $sc failed"
  diff -rq s17-main-$sc s17-split-$sc > /dev/null && echo "$sc fixed point: $(ls s17-split-$sc | wc -l) files byte-identical main vs split" || echo "$sc DIFFER"; done) | tee $OUT/s17/ply.txt
bash .gpu/run true > /dev/null 2>&1
(cd /tmp; for sc in dam-break; do for v in main split main split; do
  if [ $v = main ]; then m=$B/mpm-old; d=$P; else m=$M; d=/nonexistent; fi
  echo "$v $sc $(MPM_PTX_DIR=$d timeout 60 $m render --scene $sc --frames 90 --size 960x540 --no-images 2>&1 | grep 'frames via')"; done; done) | tee $OUT/s17/render.txt
