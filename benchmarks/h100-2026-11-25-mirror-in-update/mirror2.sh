#!/usr/bin/env bash
# Channel-by-channel mirror in grid_update_blocks. Old (d8720a2) vs new.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm; O=$PWD/.gpu/bin/mpm-old
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/m2
timeout 200 bash .gpu/run $(ls .gpu/tests/gpu_kernels-*) > $OUT/m2/gpu_kernels.log 2>&1; echo "gpu_kernels rc $?"; grep -E "^test result|FAILED|panicked" $OUT/m2/gpu_kernels.log
grep -E "tank (FixedPoint|Float), substep" $OUT/m2/gpu_kernels.log
(cd /tmp
for b in old new; do bin=$M; [ $b = old ] && bin=$O
  timeout 120 $bin run --backend cuda --scene dam-break --scatter fixed-point --frames 40 --export $b > /dev/null 2>&1 || echo "run $b failed"; done
diff -rq old new > /dev/null && echo "dam-break fixed point: $(ls new | wc -l) files byte-identical old vs new" || echo "DIFFER"
b() { timeout 100 "$@" 2>&1 | grep -E "^### |^\| " ; }
for args in "--scene bench-65k" "--scene dam-break" "--scene bench-655k" "--scene dam-break --scatter fixed-point" "--scene dam-break-1m"; do for bin in $O $M $O $M; do
  echo "== $(basename $bin) $args"; b $bin bench $args --steps 2000
done; done > $OUT/m2/bench.txt
grep -E "^== |^\| \*\*total|grid_update_blocks|one_pass" $OUT/m2/bench.txt | cut -c1-100)
for bin in $O $M; do timeout 120 ncu --clock-control none -k regex:"grid_update_blocks|mirror_walls|clear_crossing" --launch-skip 30 --launch-count 6 --section LaunchStats --section SpeedOfLight --section Occupancy --csv $bin bench --scene dam-break --steps 30 --warmup 10 > $OUT/m2/ncu-$(basename $bin).csv 2>&1; grep -E "Registers Per|\"Duration|Achieved Occupancy" $OUT/m2/ncu-$(basename $bin).csv | awk -F'","' '{print $5, $13, $15}' | head -12; done
tar czf $OUT/mirror2.tgz -C $OUT m2
