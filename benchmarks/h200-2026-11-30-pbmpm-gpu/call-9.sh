#!/usr/bin/env bash
# Session 25 call 9: jelly-drop under pbmpm at 8 and 16 substeps a frame (4 blew up, as on the CPU).
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
for s in 8 16; do
  timeout 150 $P/mpm run --backend cuda --scene .gpu-exp/scenes/pb-jd-s$s.toml --frames 180 > $L/run-jd-s$s.txt 2>&1; echo "== s$s rc $?"
  awk 'NR%15==2 || /error/' $L/run-jd-s$s.txt | cut -c1-170; tail -n 1 $L/run-jd-s$s.txt
done
tar -czf $OUT/logs.tgz -C /tmp logs
