#!/usr/bin/env bash
# Call 2: one_pass's float path without barriers (warp-level node-block marks), dead warps skipped;
# against HEAD's one_pass PTX (head) and the skip-only variant; grid of 6 or 12 blocks per SM.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s2
run_v() { local v=$1; shift; local d=/nonexistent g=""
  case $v in head) d=$PWD/.gpu/ptx-head;; skip) d=$PWD/.gpu/ptx-skip;; new6) g=6;; new12) g=12;; esac
  MPM_PTX_DIR=$d MPM_ONE_PASS_BLOCKS_PER_SM=$g timeout 90 $M "$@"; }
export -f run_v 2>/dev/null
for sc in "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break --scatter fixed-point" "--particles 16777216 --grid 256"; do
  steps=2000; vs="head skip new new6 new12"; [[ $sc == *16777216* ]] && { steps="300 --warmup 100"; vs="head new new6"; }
  for r in 1 2; do for v in $vs; do
    [[ $sc == *fixed* ]] && [[ $v == new6 || $v == new12 ]] && continue
    echo "== $v $sc"; run_v $v bench $sc --steps $steps | grep -E "one_pass \(|total"
done; done; done 2>&1 | tee $OUT/s2/bench.txt | grep -E "==|total" | paste - - | awk -F'|' '{print $1, $3}'
(cd /tmp
for sc in dam-break fountain; do for v in head new; do
  d=/nonexistent; [ $v = head ] && d=$OLDPWD/.gpu/ptx-head
  MPM_PTX_DIR=$d timeout 120 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export s2-$v-$sc > /dev/null 2>&1 || echo "run $v $sc failed"; done
  diff -rq s2-head-$sc s2-new-$sc > /dev/null && echo "$sc fixed point: $(ls s2-new-$sc | wc -l) files byte-identical head vs new" || echo "$sc DIFFER"; done) | tee $OUT/s2/ply.txt
sc=$PWD/.gpu/scenes/dam-break-crossing.toml
for tool in memcheck racecheck; do for s in float fixed-point; do timeout 100 compute-sanitizer --tool $tool --error-exitcode 9 $M run --backend cuda --scene $sc --frames 2 --scatter $s > /tmp/san.log 2>&1; echo "$tool crossing $s: rc=$? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/san.log)"; done; done | tee $OUT/s2/sanitize.txt
timeout 240 bash .gpu/run .gpu/tests/all > $OUT/s2/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s2/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s2/tests.log | head
