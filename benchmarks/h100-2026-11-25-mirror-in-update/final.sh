#!/usr/bin/env bash
# The whole GPU suite, and compute-sanitizer on the fused grid update's mirror (a grid whose walls'
# reach crosses node blocks in y and z: 40 x 21 x 22), float and fixed point, one and two ranks.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/f
timeout 330 bash .gpu/run .gpu/tests/all > $OUT/f/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/f/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/f/tests.log | head
sc=$PWD/.gpu/scenes/dam-break-crossing.toml
check() { tool=$1; shift; timeout 200 compute-sanitizer --tool $tool --print-limit 10 --error-exitcode 9 .gpu/bin/mpm run --backend cuda "$@" > /tmp/san.log 2>&1
  echo "$tool $*: rc=$? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/san.log | tr '\n' ' ')"; }
(for tool in memcheck racecheck; do
  for s in float fixed-point; do check $tool --scene $sc --frames 2 --scatter $s; done
  check $tool --scene $sc --frames 2 --scatter fixed-point --ranks 2
done) 2>&1 | sed "s|$PWD/||" | tee $OUT/f/sanitize.txt
tar czf $OUT/final.tgz -C $OUT f
