#!/bin/bash
set -u
P=/tmp/p2; mkdir -p $P; tar -C $P -xJf .gpu-exp/pack/pack.tar.xz
L=/tmp/logs; mkdir -p $L
export BACKEND=cuda
run() { local name=$1; shift; ( env "$@" timeout 500 $P/${BIN} --nocapture > $L/$name.log 2>&1; echo "rc $?" >> $L/$name.log ) & }
for d in 0.005 0.0025 0.00125; do
  BIN=scratch_sand run lubeps$d CONE=plane-strain PHI=30 DX=$d
  BIN=scratch_sand run lubetri$d PHI=30 DX=$d
done
BIN=scratch_pile run pile5 CONE=plane-strain PHI=30 DX=0.005 CAP=64000 RATE=2e-4 SPEED=0.6 POUR=5 SETTLE=1
BIN=scratch_pile run pile25 CONE=plane-strain PHI=30 DX=0.0025 CAP=512000 RATE=2e-4 SPEED=1.2 POUR=5 SETTLE=1
BIN=scratch_pile run pile5tri PHI=30 DX=0.005 CAP=64000 RATE=2e-4 SPEED=0.6 POUR=5 SETTLE=1
BIN=scratch_snow run snow8 DX=0.0025 SECONDS=0.3
BIN=scratch_snow run jelly8 DX=0.0025 SECONDS=0.3 LAW=fixed-corotated
BIN=scratch_snow run snow15 DX=0.0025 SECONDS=0.3 SPEED=15
BIN=scratch_snow run snowE DX=0.0025 SECONDS=0.3 E=4.8e4
BIN=scratch_snow run snowTs DX=0.0025 SECONDS=0.3 EXTRA="critical_stretch = 5.0e-3"
wait
for f in $L/*.log; do echo "=== $f"; grep -E "RESULT|FRONTS|PROFILE|^t=|panicked|rc |blowing" -A1 $f | grep -v "^--" | tail -30; done > $OUT/all.txt
