#!/usr/bin/env bash
# The whole GPU suite at main, and memcheck on the crossing dam break.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s
timeout 330 bash .gpu/run .gpu/tests/all > $OUT/s/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s/tests.log | head
sc=$PWD/.gpu/scenes/dam-break-crossing.toml
for s in float fixed-point; do timeout 100 compute-sanitizer --tool memcheck --error-exitcode 9 .gpu/bin/mpm run --backend cuda --scene $sc --frames 2 --scatter $s > /tmp/san.log 2>&1; echo "memcheck crossing $s: rc=$? $(grep 'ERROR SUMMARY' /tmp/san.log)"; done | tee $OUT/s/sanitize.txt
tar czf $OUT/suite.tgz -C $OUT s
