#!/bin/bash
set -u
P=/tmp/p4; mkdir -p $P; tar -C $P -xJf .gpu-exp/pack/pack.tar.xz
L=/tmp/logs4; mkdir -p $L
export BACKEND=cuda
run() { local name=$1; shift; ( env "$@" timeout 400 $P/${BIN} --nocapture > $L/$name.log 2>&1; echo "rc $?" >> $L/$name.log ) & }
for d in 0.01 0.005 0.0025 0.00125; do
  BIN=scratch_gate run gatetri$d DX=$d
  BIN=scratch_gate run gateps$d DX=$d CONE=plane-strain
done
BIN=scratch_gate run gatetri_slow0.0025 DX=0.0025 LIFT=0.02 SECONDS=7
BIN=scratch_gate run gatetri_fast0.0025 DX=0.0025 LIFT=0.1
wait
for f in $L/*.log; do echo "=== $f"; grep -E "^t=|panicked|PROFILE|rc |blowing" -A1 $f | grep -v "^--" | tail -4 | cut -c1-250; done > $OUT/all.txt
