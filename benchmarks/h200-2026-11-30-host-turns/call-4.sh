#!/usr/bin/env bash
# Session 24 call 4: host time of graph captures; captured substeps updated in place
# (cuGraphExecUpdate, MPM_GRAPH_UPDATE=1) against acfda89 (mpm-old).
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm PATH=$PATH:/usr/local/cuda/bin
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
printf '#!/bin/sh\nMPM_GRAPH_UPDATE=1 exec %s "$@"\n' $P/mpm > $P/mpm-upd; chmod +x $P/mpm-upd
for s in bench-65k dam-break dam-break-1m; do for u in 0 1; do
  echo "$s update=$u: $( (if [ $u = 1 ]; then export MPM_GRAPH_UPDATE=1; fi; MPM_HOST_PROFILE=1 timeout 60 $P/mpm bench --scene $s --steps 1000 --warmup 100 2>&1) | grep -E 'host profile|graph update refused|Wall clock|^\| \*\*total' | sort | uniq -c | tr '\n' ' ')"
done; done | tee $OUT/host.txt
STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab1 timeout 150 bash scripts/bench-ab.sh $P/mpm-old $P/mpm-upd \
  "--scene bench-65k" "--scene dam-break" "--scene dam-break-1m" "--scene dam-break --scatter fixed-point" > $OUT/ab.txt 2>&1
grep '^| `' $OUT/ab.txt
for f in /tmp/ab1/case*.log; do echo "$f $(grep -o 'Wall clock: [0-9.]*' $f)"; done | tee $OUT/wall.txt
for r in 1 2; do for m in mpm-old mpm-upd; do echo "$m round $r: $(MPM_HOST_PROFILE=1 timeout 60 $P/$m render --backend cuda --scene dam-break-1m --size 960x540 --frames 90 --no-images 2>&1 | grep -E 'sim .* ms|host profile' | tr '\n' ' ')"; done; done | tee $OUT/render.txt
for r in 1; do for m in mpm-old mpm-upd; do echo "$m dam-break round $r: $(MPM_HOST_PROFILE=1 timeout 60 $P/$m render --backend cuda --scene dam-break --size 960x540 --frames 90 --no-images 2>&1 | grep -E 'sim .* ms|host profile' | tr '\n' ' ')"; done; done | tee -a $OUT/render.txt
OUT=/tmp/bytes timeout 150 bash .gpu-exp/split-bytes.sh $P/mpm-old $P/mpm-upd 3 > /tmp/bytes.txt 2>&1; echo "bytes rc $?" >> /tmp/bytes.txt; tail -4 /tmp/bytes.txt | tee $OUT/bytes.txt
