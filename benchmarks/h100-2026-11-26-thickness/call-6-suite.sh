#!/usr/bin/env bash
# At acdf1e2: the whole suite, the bench's rebinning label, a render of each draw mode's thickness path.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s49
$M bench --scene dam-break --steps 200 2>&1 | grep -iE "rebin|sort" | head -2
MPM_BIN_ORDER=0 $M bench --scene dam-break --steps 200 2>&1 | grep -iE "rebin|sort" | head -2
for t in interop host-copy; do timeout 100 $M render --scene fountain --frames 20 --size 960x540 --transfer $t --no-images 2>&1 | grep -E "frames via|GPU ms"; done
timeout 60 $M render --scene dam-break --backend cpu-parallel --frames 5 --size 480x270 --no-images 2>&1 | grep -E "GPU ms" 
timeout 420 bash .gpu/tests/all > $OUT/s49/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s49/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s49/tests.log | head -20
