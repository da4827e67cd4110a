#!/usr/bin/env bash
# grid_update_blocks register caps through MPM_PTX_DIR: none (96 registers) vs 12 and 16 blocks per SM.
export NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/lb
b() { timeout 100 "$@" 2>&1 | grep -E "^\| \*\*total|grid_update_blocks" ; }
for args in "--scene bench-65k" "--scene dam-break" "--scene bench-655k" "--scene dam-break --scatter fixed-point"; do for rep in 1 2; do for v in none 12 16; do
  echo "== $v $args"; if [ $v = none ]; then b $M bench $args --steps 2000; else MPM_PTX_DIR=$PWD/.gpu/ptx-lb$v b $M bench $args --steps 2000; fi
done; done; done > $OUT/lb/bench.txt
grep -E "^== |total" $OUT/lb/bench.txt | cut -c1-60 | paste - -
for v in 12 16; do MPM_PTX_DIR=$PWD/.gpu/ptx-lb$v timeout 120 ncu --clock-control none -k regex:"grid_update_blocks" --launch-skip 30 --launch-count 2 --section LaunchStats --section Occupancy --section SpeedOfLight --csv $M bench --scene dam-break --steps 30 --warmup 10 > $OUT/lb/ncu-$v.csv 2>&1; echo "lb$v"; grep -E "Registers Per|Achieved Occupancy|\"Duration" $OUT/lb/ncu-$v.csv | awk -F'","' '{print $5, $13, $15}' | head -6; done
tar czf $OUT/lb.tgz -C $OUT lb
