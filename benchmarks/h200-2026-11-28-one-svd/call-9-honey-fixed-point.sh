#!/usr/bin/env bash
# Device call 9: the honey coiling check in the fixed-point scatter, twice (deterministic?).
set -u
cd "$(dirname "$0")/.." || exit 1
P=/tmp/p9; mkdir -p $P && tar -xJf .gpu-exp/pack/pack.tar.xz -C $P
L=$OUT/logs; mkdir -p $L
for run in fixed1 fixed2; do
  timeout 100 $P/gpu_materials the_honey_preset_s_rope_coils --nocapture > $L/$run.log 2>&1
  echo "$run: $(grep -E "rope's foot|test result|panicked" $L/$run.log | tr '\n' ' ')"
done
