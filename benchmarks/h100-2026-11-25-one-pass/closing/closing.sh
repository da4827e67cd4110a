#!/usr/bin/env bash
# Call 7: main at 5ebd31d. The whole suite; PLY bytes and headless frames against the session's start
# e52c00c (start: all its PTX through MPM_PTX_DIR; the host code is unchanged since); sanitizers;
# ncu stall sampling of one_pass at the dam break after the change.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s7
timeout 270 bash .gpu/run .gpu/tests/all > $OUT/s7/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s7/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s7/tests.log | head
(cd /tmp; R=$OLDPWD
for sc in dam-break fountain; do for v in start head; do d=/nonexistent; [ $v = start ] && d=$R/.gpu/ptx-start
  MPM_PTX_DIR=$d timeout 60 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export s7-$v-$sc > /dev/null 2>&1 || echo "run $v $sc failed"; done
  diff -rq s7-start-$sc s7-head-$sc > /dev/null && echo "$sc fixed point: $(ls s7-head-$sc | wc -l) files byte-identical e52c00c vs 5ebd31d" || echo "$sc DIFFER"; done) | tee $OUT/s7/ply.txt
for sc in dam-break dam-break-1m; do for v in start head start head; do d=/nonexistent; [ $v = start ] && d=$PWD/.gpu/ptx-start
  echo "== $v render $sc"; MPM_PTX_DIR=$d timeout 40 $M render --scene $sc --frames 90 --size 960x540 --no-images 2>&1 | grep "frames via"; done; done | tee $OUT/s7/render.txt
sc=$PWD/.gpu/scenes/dam-break-crossing.toml
for tool in memcheck racecheck; do for s in float fixed-point; do timeout 45 compute-sanitizer --tool $tool --error-exitcode 9 $M run --backend cuda --scene $sc --frames 2 --scatter $s > /tmp/san.log 2>&1; echo "$tool crossing $s: rc=$? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/san.log)"; done; done | tee $OUT/s7/sanitize.txt
timeout 60 ncu --clock-control none --set full --import-source yes -k regex:one_pass --launch-skip 30 --launch-count 1 -o $OUT/s7/op-dam $M bench --scene dam-break --steps 40 --warmup 10 > $OUT/s7/ncu.log 2>&1; echo "ncu rc $?"
ncu -i $OUT/s7/op-dam.ncu-rep --page source --csv --print-source sass > $OUT/s7/op-sass.csv 2>&1
ncu -i $OUT/s7/op-dam.ncu-rep --page details --csv > $OUT/s7/op-details.csv 2>&1; rm -f $OUT/s7/op-dam.ncu-rep
