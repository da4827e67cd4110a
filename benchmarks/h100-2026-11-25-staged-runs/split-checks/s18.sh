#!/usr/bin/env bash
# Call 7: the same build as call 6 (one_pass_float / one_pass_fixed): sanitizers, then the whole suite.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
mkdir -p $OUT/s18
sc=$PWD/.gpu/scenes/dam-break-crossing.toml
for tool in memcheck racecheck; do for s in float fixed-point; do timeout 45 compute-sanitizer --tool $tool --error-exitcode 9 $M run --backend cuda --scene $sc --frames 2 --scatter $s > /tmp/san.log 2>&1; echo "$tool crossing $s: rc=$? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/san.log)"; done; done | tee $OUT/s18/sanitize.txt
timeout 300 bash .gpu/run .gpu/tests/all > $OUT/s18/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s18/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s18/tests.log | head -20
