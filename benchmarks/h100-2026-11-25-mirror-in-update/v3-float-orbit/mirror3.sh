#!/usr/bin/env bash
# Float orbit loaded at once (v3) vs channel by channel (v2) vs old (d8720a2).
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm; O=$PWD/.gpu/bin/mpm-old; V=$PWD/.gpu/bin/mpm-v2
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/m3
timeout 200 bash .gpu/run $(ls .gpu/tests/gpu_kernels-*) > $OUT/m3/gpu_kernels.log 2>&1; echo "gpu_kernels rc $?"; grep -E "^test result|FAILED|panicked" $OUT/m3/gpu_kernels.log
grep -E "tank (FixedPoint|Float), substep" $OUT/m3/gpu_kernels.log
(cd /tmp
b() { timeout 100 "$@" 2>&1 | grep -E "^### |^\| " ; }
for args in "--scene bench-65k" "--scene dam-break" "--scene bench-655k" "--scene bench-65k --scatter fixed-point"; do for bin in $O $V $M $O $V $M; do
  echo "== $(basename $bin) $args"; b $bin bench $args --steps 2000
done; done > $OUT/m3/bench.txt
grep -E "^== |^\| \*\*total" $OUT/m3/bench.txt | cut -c1-60 | paste - - )
timeout 120 ncu --clock-control none -k regex:"grid_update_blocks" --launch-skip 30 --launch-count 2 --section LaunchStats --section Occupancy --csv $M bench --scene dam-break --steps 30 --warmup 10 > $OUT/m3/ncu.csv 2>&1; grep -E "Registers Per|Achieved Occupancy" $OUT/m3/ncu.csv | awk -F'","' '{print $5, $13, $15}' | head -4
tar czf $OUT/mirror3.tgz -C $OUT m3
