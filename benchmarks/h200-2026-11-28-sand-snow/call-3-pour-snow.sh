#!/bin/bash
set -u
P=/tmp/p3; mkdir -p $P; tar -C $P -xJf .gpu-exp/pack/pack.tar.xz
L=/tmp/logs3; mkdir -p $L
export BACKEND=cuda
run() { local name=$1; shift; ( env "$@" timeout 520 $P/${BIN} --nocapture > $L/$name.log 2>&1; echo "rc $?" >> $L/$name.log ) & }
BIN=scratch_cone run cone5tri PHI=30 DX=0.005
BIN=scratch_cone run cone5ps PHI=30 DX=0.005 CONE=plane-strain
BIN=scratch_cone run cone25tri PHI=30 DX=0.0025
BIN=scratch_cone run cone5tri_slow PHI=30 DX=0.005 RATE=2.5e-4 SECONDS=11
BIN=scratch_snow run snowTs5 DX=0.005 SECONDS=0.4 EXTRA="critical_stretch = 5.0e-3"
BIN=scratch_snow run snowTs25 DX=0.0025 SECONDS=0.4 EXTRA="critical_stretch = 5.0e-3"
BIN=scratch_snow run jelly25 DX=0.0025 SECONDS=0.4 LAW=fixed-corotated
BIN=scratch_snow run snowTs25_fixed DX=0.0025 SECONDS=0.4 EXTRA="critical_stretch = 5.0e-3" SOLVER='[solver]
scatter = "fixed-point"'
wait
for f in $L/*.log; do echo "=== $f"; grep -E "^t=|panicked|PROFILE|rc |blowing" -A1 $f | grep -v "^--" | tail -16; done > $OUT/all.txt
