#!/usr/bin/env bash
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm; O=$PWD/.gpu/bin/mpm-old
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/f
(cd /tmp; b() { timeout 100 "$@" 2>&1 | grep -E "^### |\*\*total|one_pass" ; }
for args in "--scene dam-break --steps 2000" "--scene bench-655k --steps 2000" "--particles 16777216 --grid 256 --steps 300 --warmup 100"; do for bin in $O $M $O $M; do
  echo "== $(basename $bin) $args"; b $bin bench $args
done; done > $OUT/f/bench-float.txt
grep -E "^== |total" $OUT/f/bench-float.txt | cut -c1-80)
timeout 420 bash .gpu/run .gpu/tests/all > $OUT/f/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result|^not run|FAILED|panicked" $OUT/f/tests.log | sort | uniq -c | sort -rn | head -20
grep -E "^test result" $OUT/f/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
tar czf $OUT/final.tgz -C $OUT f
