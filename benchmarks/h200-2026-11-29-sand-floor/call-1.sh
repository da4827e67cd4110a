#!/usr/bin/env bash
# Sand columns (a = 0.5, 3) on a stick floor and on a Coulomb floor (friction 0.577, the mirror off),
# at 2.5 and 1.25 mm, on the GPU (the scratch test tests/scratch_sand.rs of this session).
set -u
P=/tmp/p1; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
DX=0.0025,0.00125 FLOOR=stick,coulomb BACKEND=cuda timeout 540 $P/scratch_sand --nocapture 2>&1 | grep -E "RESULT|t = 1.50|panicked" | tee $OUT/call-1.log
