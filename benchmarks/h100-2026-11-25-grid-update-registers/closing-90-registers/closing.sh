#!/usr/bin/env bash
# Closing run at main: the whole GPU suite, memcheck on the crossing dam break, the session's
# before/after (d8720a2 = mpm-old) on the benches and the headless frame.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm; O=$PWD/.gpu/bin/mpm-old
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/c
timeout 330 bash .gpu/run .gpu/tests/all > $OUT/c/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/c/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/c/tests.log | head
sc=$PWD/.gpu/scenes/dam-break-crossing.toml
for s in float fixed-point; do timeout 200 compute-sanitizer --tool memcheck --error-exitcode 9 $M run --backend cuda --scene $sc --frames 2 --scatter $s > /tmp/san.log 2>&1; echo "memcheck crossing $s: rc=$? $(grep 'ERROR SUMMARY' /tmp/san.log)"; done | tee $OUT/c/sanitize.txt
(cd /tmp
for sc in dam-break fountain; do for b in old new; do bin=$M; [ $b = old ] && bin=$O
  timeout 120 $bin run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export c-$b-$sc > /dev/null 2>&1 || echo "run $b $sc failed"; done
  diff -rq c-old-$sc c-new-$sc > /dev/null && echo "$sc fixed point: $(ls c-new-$sc | wc -l) files byte-identical d8720a2 vs main" || echo "$sc DIFFER"; done
b() { timeout 150 "$@" 2>&1 | grep -E "^### |^\| " ; }
for args in "--scene bench-65k" "--scene dam-break" "--scene bench-655k" "--scene bench-655k --scatter fixed-point" "--scene dam-break-1m" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $args == *16777216* ]] && steps="300 --warmup 100"
  for bin in $O $M; do echo "== $(basename $bin) $args"; b $bin bench $args --steps $steps; done; done > $OUT/c/bench.txt
grep -E "^== |total\*\*" $OUT/c/bench.txt | paste - - | awk -F'|' '{print $1, $3}'
for sc in dam-break dam-break-1m; do for bin in $O $M; do echo "== $(basename $bin) render $sc"; timeout 150 $bin render --scene $sc --frames 90 --size 960x540 --no-images 2>&1 | tail -4; done; done > $OUT/c/render.txt
grep -E "^==|ms per frame|sim|per frame" $OUT/c/render.txt | head -24)
tar czf $OUT/closing.tgz -C $OUT c
