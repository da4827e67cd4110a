#!/usr/bin/env bash
# Call 6: the fixed-point flush over the box the chunk's stencils reached (box, embedded) against
# main at 5ebd31d (h5: its one_pass PTX) and the session's start e52c00c (start: all its PTX; the host
# code is unchanged since). Benches, headless frames, PLY bytes, sanitizers, the whole suite.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s6
run_v() { local v=$1; shift; local d=/nonexistent
  case $v in start) d=$PWD/.gpu/ptx-start;; h5) d=$PWD/.gpu/ptx-h5;; esac
  MPM_PTX_DIR=$d timeout 120 $M "$@"; }
for sc in "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break-1m" "--scene dam-break --pipeline binned" "--particles 16777216 --grid 256" "--particles 16777216 --grid 256 --scatter fixed-point"; do
  steps=2000; vs="start h5 box"; [[ $sc == *16777216* ]] && steps="300 --warmup 100"
  [[ $sc == *binned* ]] && vs="start box"
  for r in 1 2; do for v in $vs; do
    echo "== $v $sc"; run_v $v bench $sc --steps $steps 2>&1 | grep -E "one_pass \(|total|panic"
done; done; done > $OUT/s6/bench.txt 2>&1
python3 - $OUT/s6/bench.txt <<'PY'
import sys,collections
cur=None; res=collections.defaultdict(list); op=collections.defaultdict(list)
for line in open(sys.argv[1]):
    if line.startswith('=='): cur=line[3:].strip(); continue
    c=[x.strip() for x in line.split('|')]
    if len(c)>2 and 'total' in c[1]: res[cur].append(float(c[2]))
    elif len(c)>2 and c[1].startswith('one_pass'): op[cur].append(float(c[2]))
for k in res: print(f"{k:62s} total {res[k]}  one_pass {op[k]}")
PY
for sc in dam-break dam-break-1m; do for v in start box; do echo "== $v render $sc"; run_v $v render --scene $sc --frames 90 --size 960x540 --no-images 2>&1 | tail -4; done; done > $OUT/s6/render.txt 2>&1
grep -E "^==|per frame" $OUT/s6/render.txt | head -16
(cd /tmp; R=$OLDPWD
for sc in dam-break fountain; do for v in start box; do d=/nonexistent; [ $v = start ] && d=$R/.gpu/ptx-start
  MPM_PTX_DIR=$d timeout 120 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export s6-$v-$sc > /dev/null 2>&1 || echo "run $v $sc failed"; done
  diff -rq s6-start-$sc s6-box-$sc > /dev/null && echo "$sc fixed point: $(ls s6-box-$sc | wc -l) files byte-identical e52c00c vs box" || echo "$sc DIFFER"; done) | tee $OUT/s6/ply.txt
sc=$PWD/.gpu/scenes/dam-break-crossing.toml
for tool in memcheck racecheck; do for s in float fixed-point; do timeout 100 compute-sanitizer --tool $tool --error-exitcode 9 $M run --backend cuda --scene $sc --frames 2 --scatter $s > /tmp/san.log 2>&1; echo "$tool crossing $s: rc=$? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/san.log)"; done; done | tee $OUT/s6/sanitize.txt
timeout 230 bash .gpu/run .gpu/tests/all > $OUT/s6/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s6/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s6/tests.log | head
