#!/usr/bin/env bash
# At HEAD (0917946): the whole suite; which path each scene's thickness takes; the render figures once more.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s52
for sc in "fountain --size 960x540" "bench-65k --size 960x540" "dam-break --size 960x540" "dam-break --size 1920x1080" "dam-break-1m --size 960x540"; do
  echo "== $sc"; timeout 120 $M render --scene $sc --frames 90 --no-images 2>&1 | grep -E "frames via|GPU ms"; done | tee $OUT/s52/render.txt
timeout 420 bash .gpu/tests/all > $OUT/s52/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s52/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s52/tests.log | head -20
