#!/usr/bin/env bash
set -u
export NCCL_NVLS_ENABLE=0
R=/tmp/results; mkdir -p $R
bash .gpu/run true
for round in 1 2; do
  for v in mpm-nooverlap mpm; do
    bash scripts/view-on-gpu.sh --frames 300 --mpm .gpu/bin/$v --out $R/$v-$round > $R/$v-$round.script.log 2>&1
    echo "== $v round $round"; grep "^viewer:" $R/$v-$round/view.log | tail -3
  done
done
bash scripts/view-on-gpu.sh --frames 300 --mpm .gpu/bin/mpm --out $R/mpm-fullres -- --full-res-smoothing > $R/fullres.script.log 2>&1
echo "== mpm --full-res-smoothing"; grep "^viewer:" $R/mpm-fullres/view.log | tail -3
for v in mpm-nooverlap mpm; do
  bash scripts/view-on-gpu.sh --frames 300 --mpm .gpu/bin/$v --out $R/$v-points -- --draw points > $R/$v-points.script.log 2>&1
  echo "== $v points"; grep "^viewer:" $R/$v-points/view.log | tail -3
done
tar czf $OUT/viewer3.tgz -C $R .
