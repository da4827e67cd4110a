#!/usr/bin/env bash
# No timing event for a phase without work (the sort between binnings, the fused p2g): old (fbb9437) against new.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm; O=$PWD/.gpu/bin/mpm-old
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/e
(cd /tmp
b() { timeout 100 "$@" 2>&1 | grep -E "^### |^\| " ; }
for args in "--scene bench-65k" "--scene bench-655k" "--scene dam-break" "--scene bench-65k --pipeline binned" "--scene bench-65k --pipeline report"; do for bin in $O $M $O $M; do
  echo "== $(basename $bin) $args"; b $bin bench $args --steps 2000
done; done > $OUT/e/bench.txt
grep -E "^== |total" $OUT/e/bench.txt | cut -c1-80
timeout 60 $M run --scene dam-break --frames 20 --stats s.jsonl > $OUT/e/run.log 2>&1; echo "run rc $?"; tail -2 $OUT/e/run.log; tail -1 s.jsonl | cut -c1-400)
timeout 400 bash .gpu/run .gpu/tests/all > $OUT/e/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/e/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked" $OUT/e/tests.log | head
tar czf $OUT/events.tgz -C $OUT e
