#!/usr/bin/env bash
set -u
cd "$(dirname "$0")/.." || exit 1
mkdir -p /tmp/p && tar -xJf .gpu-exp/pack/pack.tar.xz -C /tmp/p
export MPM_BIN=/tmp/p/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name --format=csv,noheader
L=$OUT/logs; mkdir -p $L
timeout 300 /tmp/p/mpm bench --scene bench-655k --scene benches/scenes/bench-655k-jelly.toml --scene benches/scenes/bench-655k-sand.toml --scene benches/scenes/bench-655k-snow.toml --steps 500 --warmup 100 > $L/bench.md 2>&1
( timeout 450 /tmp/p/gpu_solids --nocapture > $L/gpu_solids.log 2>&1; echo "rc $?" >> $L/gpu_solids.log ) &
( SWEEP=buoy,snow timeout 450 /tmp/p/gpu_sweep --nocapture > $L/sweep1.log 2>&1; echo "rc $?" >> $L/sweep1.log ) &
( SWEEP=sand timeout 450 /tmp/p/gpu_sweep --nocapture > $L/sweep2.log 2>&1; echo "rc $?" >> $L/sweep2.log ) &
wait
grep -E "^(BUOY|SAND|SNOW)" $L/sweep*.log
grep -E "^test |buoyancy|dx = |sand column|ball at|step 300|panicked|rc " $L/gpu_solids.log | head -40
grep -E "^\|" $L/bench.md | head -40
tar -czf $OUT/logs.tgz -C $OUT logs
