#!/usr/bin/env bash
# Call 4 (one H200): e5c49dd, gpu_ranks with 4 ranks on one GPU beside 2 and 3; and where the host
# spends a substep of `fountain` on 2 ranks (MPM_RANKS_HOST_TIMES=1), against the same ranks without
# emitters and sinks (the coarse dam break) and `fountain` on one GPU.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
timeout 200 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_ranks --out /tmp/tests --timeout 195 > $OUT/tests.txt 2>&1
tail -3 $OUT/tests.txt; cp /tmp/tests/gpu_ranks.log $OUT/
M=$PWD/.gpu/bin/mpm; cd /tmp
for args in "--scene fountain" "--scene fountain --ranks 2" "--scene dam-break-coarse --ranks 2"; do
  echo "== mpm run --backend cuda --scatter fixed-point $args --frames 90" >> $OUT/host.txt
  start=$SECONDS
  MPM_RANKS_HOST_TIMES=1 timeout 120 $M run --backend cuda --scatter fixed-point $args --frames 90 > run.log 2>&1
  echo "rc $? in $((SECONDS - start)) s" >> $OUT/host.txt
  grep -E "^frame +90|host time" run.log >> $OUT/host.txt
done
cat $OUT/host.txt; echo "done at $SECONDS s"
