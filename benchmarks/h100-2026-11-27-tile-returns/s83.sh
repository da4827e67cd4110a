#!/usr/bin/env bash
# The session's fixed-point tile (4ebc6d8, the binary's own kernels) against be487f5's kernels
# (ptx-head), each twice and interleaved, for the record; the float bench-655k for the ratio; then
# the whole suite at 4ebc6d8.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s83
cases=("--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break-1m --scatter fixed-point" "--scene fountain --scatter fixed-point" "--scene dam-break --pipeline binned --scatter fixed-point" "--scene bench-655k --pipeline binned --scatter fixed-point" "--scene bench-655k" "--particles 16777216 --grid 256 --scatter fixed-point")
OUT=$OUT/s83/ab RUNS=2 bash scripts/bench-ab.sh $M@$G/ptx-head $M "${cases[@]}" 2>&1 | grep "^| " | tee $OUT/s83/ab.txt
timeout 330 bash .gpu/tests/all > $OUT/s83/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s83/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s83/tests.log | head -20
