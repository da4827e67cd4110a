#!/usr/bin/env bash
# The float scatter by planes (one_pass_float_planes) against by runs, by size; the size rule's pick
# against HEAD 69d4162 (its binary's host code with its committed kernels); sanitizers; kernel tests.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s57 /tmp/w
printf '#!/bin/sh\nMPM_FLOAT_SCATTER=runs exec %s "$@"\n' $M > /tmp/w/mpm-runs; printf '#!/bin/sh\nMPM_FLOAT_SCATTER=planes exec %s "$@"\n' $M > /tmp/w/mpm-planes; chmod +x /tmp/w/*
sizes=("--scene bench-65k" "--particles 131072" "--particles 196608" "--particles 262144" "--particles 393216" "--particles 524288" "--scene fountain" "--scene dam-break" "--scene bench-655k" "--scene dam-break-1m")
OUT=$OUT/s57/sizes RUNS=2 bash scripts/bench-ab.sh /tmp/w/mpm-runs /tmp/w/mpm-planes "${sizes[@]}" 2>&1 | grep "^| " | tee $OUT/s57/sizes.txt
cases=("--scene bench-65k" "--scene dam-break" "--scene bench-655k" "--scene dam-break-1m" "--scene fountain" "--scene dam-break --scatter fixed-point")
OUT=$OUT/s57/head RUNS=2 bash scripts/bench-ab.sh $G/old/mpm-head@$G/ptx-head $M "${cases[@]}" 2>&1 | grep "^| " | tee $OUT/s57/head.txt
OUT=$OUT/s57/head16 RUNS=2 STEPS=300 WARMUP=100 bash scripts/bench-ab.sh $G/old/mpm-head@$G/ptx-head $M "--particles 16777216 --grid 256" 2>&1 | grep "^| \`" | tee -a $OUT/s57/head.txt
sc=$PWD/benchmarks/h100-2026-11-25-mirror-in-update/dam-break-crossing.toml
for tool in memcheck racecheck; do for s in runs planes; do MPM_FLOAT_SCATTER=$s timeout 90 compute-sanitizer --tool $tool --error-exitcode 9 $M run --backend cuda --scene $sc --frames 2 > /tmp/san.log 2>&1; echo "$tool crossing float $s: rc=$? $(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' /tmp/san.log)"; done; done | tee $OUT/s57/sanitize.txt
for s in runs planes; do echo "== $s"; MPM_FLOAT_SCATTER=$s timeout 200 .gpu/tests/gpu_kernels-* 2>&1 | grep -E "^test result|FAILED|panicked"; done | tee $OUT/s57/tests.txt
