#!/usr/bin/env bash
# Final build of the change: the whole suite and the sanitizers.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm R=$PWD
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s35
sc=$R/benchmarks/h100-2026-11-25-mirror-in-update/dam-break-crossing.toml
for tool in memcheck racecheck; do for s in float fixed-point; do timeout 60 compute-sanitizer --tool $tool --error-exitcode 9 $M run --backend cuda --scene $sc --frames 2 --scatter $s > /tmp/san.log 2>&1; echo "$tool crossing $s: rc=$? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/san.log)"; done; done | tee $OUT/s35/sanitize.txt
for tool in memcheck racecheck; do timeout 90 compute-sanitizer --tool $tool --error-exitcode 9 $M run --backend cuda --scene fountain --frames 3 --scatter fixed-point > /tmp/san.log 2>&1; echo "$tool fountain fixed-point: rc=$? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/san.log)"; done | tee -a $OUT/s35/sanitize.txt
timeout 330 bash .gpu/run .gpu/tests/all > $OUT/s35/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s35/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run|stored away" $OUT/s35/tests.log | head -20
