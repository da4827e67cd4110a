#!/usr/bin/env bash
# Particles stored in bin order (working tree) against 06f9cc2 (mpm-head): PLY bytes, bench, frames, sanitizers.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm H=$PWD/.gpu/bin/mpm-head R=$PWD
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s32
(cd /tmp; for sc in dam-break fountain; do
  timeout 90 $H run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export h-$sc > /dev/null 2>&1 || echo "head $sc failed"
  timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export n-$sc > /dev/null 2>&1 || echo "new $sc failed"
  MPM_BIN_ORDER=0 timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export o-$sc > /dev/null 2>&1 || echo "new off $sc failed"
  diff -rq h-$sc n-$sc > /dev/null && echo "$sc fixed point: $(ls n-$sc | wc -l) files byte-identical, 06f9cc2 vs bin order" || echo "$sc DIFFER head vs bin order: $(diff -rq h-$sc n-$sc | wc -l)"
  diff -rq o-$sc n-$sc > /dev/null && echo "$sc fixed point: byte-identical, bin order off vs on" || echo "$sc DIFFER off vs on"
done) | tee $OUT/s32/ply.txt
OUT=$OUT/s32/ab bash scripts/bench-ab.sh $H $M "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene fountain" 2>&1 | grep -v "^raw" | tee $OUT/s32/bench.txt
STEPS=300 WARMUP=100 OUT=$OUT/s32/ab16 bash scripts/bench-ab.sh $H $M "--particles 16777216 --grid 256" 2>&1 | grep "^| \`" | tee -a $OUT/s32/bench.txt
python3 - $OUT/s32/ab <<'PY' | tee $OUT/s32/phases.txt
import json, sys, glob, os
for f in sorted(glob.glob(sys.argv[1] + "/*-1.json")):
    for s in json.load(open(f))["phases"]:
        print(os.path.basename(f), s["scene"], json.dumps({k: (v.get("median_ms") if isinstance(v, dict) else None) for k, v in s.items() if isinstance(v, dict)}))
PY
rm -rf $OUT/s32/ab/*.log
for sc in dam-break dam-break-1m; do for v in head new head new; do b=$M; [ $v = head ] && b=$H
  echo "== $v render $sc"; timeout 60 $b render --scene $sc --frames 90 --size 960x540 --no-images 2>&1 | grep "frames via"; done; done | tee $OUT/s32/render.txt
sc=$R/benchmarks/h100-2026-11-25-mirror-in-update/dam-break-crossing.toml
for tool in memcheck racecheck; do for s in float fixed-point; do timeout 60 compute-sanitizer --tool $tool --error-exitcode 9 $M run --backend cuda --scene $sc --frames 2 --scatter $s > /tmp/san.log 2>&1; echo "$tool crossing $s: rc=$? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/san.log)"; done; done | tee $OUT/s32/sanitize.txt
timeout 90 compute-sanitizer --tool memcheck --error-exitcode 9 $M run --backend cuda --scene fountain --frames 3 --scatter fixed-point > /tmp/san.log 2>&1; echo "memcheck fountain fixed-point: rc=$? $(grep -E 'ERROR SUMMARY' /tmp/san.log)" | tee -a $OUT/s32/sanitize.txt
