#!/usr/bin/env bash
# Session 20 call 1: Stokes at 10 cells with half the substep (issue 42); the grid update's source-level
# profile at 16.8M and the dam break (issue 47).
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p20; mkdir -p $P/tests && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P && mv $P/gpu_bodies $P/tests/
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
M=$P/mpm
S="--set full --import-source yes"
( time timeout 150 ncu --clock-control none -k regex:grid_update_blocks --launch-skip 40 --launch-count 1 $S -f -o $OUT/p16 $M bench --particles 16777216 --grid 256 --steps 50 --warmup 10 ) > $OUT/ncu-16m.log 2>&1
ncu --import $OUT/p16.ncu-rep --page source --csv --print-source sass > $OUT/src-16m.csv 2>&1
ncu --import $OUT/p16.ncu-rep --page details > $OUT/ncu-16m.txt 2>&1
( time timeout 150 ncu --clock-control none -k regex:grid_update_blocks --launch-skip 200 --launch-count 1 $S -f -o $OUT/pdam $M bench --scene dam-break --steps 250 --warmup 10 ) > $OUT/ncu-dam.log 2>&1
ncu --import $OUT/pdam.ncu-rep --page source --csv --print-source sass > $OUT/src-dam.csv 2>&1
ncu --import $OUT/pdam.ncu-rep --page details > $OUT/ncu-dam.txt 2>&1
ls -la $OUT
MPM_STOKES_CELLS=10 MPM_STOKES_CFL=0.2 timeout 400 $P/tests/gpu_bodies a_sphere_settles_at_stokes_velocity --nocapture > $OUT/stokes.log 2>&1
echo "stokes rc $?" >> $OUT/stokes.log
grep -h "cells, t =\|RESULT\|stokes rc\|finished in" $OUT/stokes.log
