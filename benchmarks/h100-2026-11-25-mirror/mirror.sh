#!/usr/bin/env bash
# One mirror launch for mass and momentum in the fused pipeline: old (fbdcf97) against new, one call.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm; O=$PWD/.gpu/bin/mpm-old
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/m
(cd /tmp
for scene in dam-break fountain; do
  for b in old new; do bin=$M; [ $b = old ] && bin=$O
    timeout 120 $bin run --backend cuda --scene $scene --scatter fixed-point --frames 60 --export $b-$scene > /dev/null 2>&1; echo "run $b $scene rc $?"
  done
  if diff -rq old-$scene new-$scene > /dev/null; then echo "$scene: fixed point, 61 PLY frames byte-identical old vs new"; else echo "$scene: DIFFER"; fi
done
b() { timeout 100 "$@" 2>&1 | grep -E "^### |\*\*total|mirror|grid_update" ; }
for args in "--scene bench-65k" "--scene bench-655k" "--scene dam-break" "--scene bench-65k --scatter fixed-point" "--scene dam-break --scatter fixed-point"; do for bin in $O $M $O $M; do
  echo "== $(basename $bin) $args"; b $bin bench $args --steps 2000
done; done > $OUT/m/bench.txt
grep -E "^== |total" $OUT/m/bench.txt | cut -c1-80)
timeout 400 bash .gpu/run .gpu/tests/all > $OUT/m/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/m/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/m/tests.log | head
tar czf $OUT/mirror.tgz -C $OUT m
