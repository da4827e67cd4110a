#!/usr/bin/env bash
set -u
export NCCL_NVLS_ENABLE=0
R=/tmp/results; mkdir -p $R
bash .gpu/run true
for round in 1 2; do
  for v in mpm-old mpm; do
    bash scripts/view-on-gpu.sh --frames 300 --mpm .gpu/bin/$v --out $R/$v-$round > $R/$v-$round.script.log 2>&1
    echo "== $v round $round: exit $?"; grep -iE "fps|real time|draw interval|step total" $R/$v-$round/view.log | tail -4
  done
done
for v in mpm-old mpm; do
  bash scripts/view-on-gpu.sh --frames 300 --mpm .gpu/bin/$v --out $R/$v-points -- --draw points > $R/$v-points.script.log 2>&1
  echo "== $v points: exit $?"; grep -iE "fps|real time" $R/$v-points/view.log | tail -2
done
tar czf $OUT/viewer.tgz -C $R .
