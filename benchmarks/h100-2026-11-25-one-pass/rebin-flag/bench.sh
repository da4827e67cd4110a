#!/usr/bin/env bash
# Call 11: one_pass's rebin flag set by one store per warp, only while it is down (far, embedded),
# against main's store per flagged thread (h6: main's one_pass PTX); then, with far embedded, the
# whole suite and the fixed-point dam break's PLY bytes against the session's start.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s11
for sc in "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $sc == *16777216* ]] && steps="300 --warmup 100"
  for r in 1 2; do for v in h6 far; do
    d=/nonexistent; [ $v = h6 ] && d=$PWD/.gpu/ptx-h6
    echo "== $v $sc"; MPM_PTX_DIR=$d timeout 90 $M bench $sc --steps $steps 2>&1 | grep -E "one_pass \(|rebin|total|panic|rror:"
done; done; done > $OUT/s11/bench.txt 2>&1
python3 - $OUT/s11/bench.txt <<'PY'
import sys,collections
cur=None; res=collections.defaultdict(list); op=collections.defaultdict(list)
for line in open(sys.argv[1]):
    if line.startswith('=='): cur=line[3:].strip(); continue
    c=[x.strip() for x in line.split('|')]
    if len(c)>2 and 'total' in c[1]: res[cur].append(float(c[2]))
    elif len(c)>2 and c[1].startswith('one_pass'): op[cur].append(float(c[2]))
for k in res: print(f"{k:50s} total {res[k]}  one_pass {op[k]}")
PY
(cd /tmp; R=$OLDPWD
for v in start far; do d=/nonexistent; [ $v = start ] && d=$R/.gpu/ptx-start
  MPM_PTX_DIR=$d timeout 60 $M run --backend cuda --scene dam-break --scatter fixed-point --frames 60 --export s11-$v > /dev/null 2>&1 || echo "run $v failed"; done
diff -rq s11-start s11-far > /dev/null && echo "dam-break fixed point: $(ls s11-far | wc -l) files byte-identical e52c00c vs far" || echo "DIFFER") | tee $OUT/s11/ply.txt
timeout 270 bash .gpu/run .gpu/tests/all > $OUT/s11/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s11/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s11/tests.log | head
