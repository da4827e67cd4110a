#!/usr/bin/env bash
# Session 23 call 3: the list passes' launch sized by the kernel's residency (MPM_EXP_LIST_WAVES=W:
# W x resident blocks x SMs) against 32 blocks x SMs (unset), one experiment build.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm PATH=$PATH:/usr/local/cuda/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
$P/mpm bench --scene bench-65k --steps 5 --warmup 0 > /dev/null 2>&1
for w in 1 2 4; do printf '#!/bin/sh\nMPM_EXP_LIST_WAVES=%s exec %s "$@"\n' $w $P/mpm > $P/mpm-w$w; chmod +x $P/mpm-w$w; done
for w in 1 2 4; do
STEPS=1500 WARMUP=100 RUNS=2 OUT=/tmp/ab-w$w timeout 150 bash scripts/bench-ab.sh $P/mpm $P/mpm-w$w "--scene bench-65k" "--scene dam-break" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" > $OUT/ab-w$w.txt 2>&1
STEPS=200 WARMUP=50 RUNS=1 OUT=/tmp/ab16-w$w timeout 90 bash scripts/bench-ab.sh $P/mpm $P/mpm-w$w "--particles 16777216 --grid 256" "--particles 16777216 --grid 256 --scatter fixed-point" >> $OUT/ab-w$w.txt 2>&1
echo "== w$w"; grep -h '^| `' $OUT/ab-w$w.txt
done
for f in /tmp/ab*-w*/case*-1.log; do echo "== $f $(grep -E '^\| (mirror_walls)' $f | awk -F'|' '{print $3, $8}') $(grep -E '^\| (gather_volume)' $f | awk -F'|' '{print $3, $8}')"; done > $OUT/phases.txt 2>&1; cat $OUT/phases.txt
