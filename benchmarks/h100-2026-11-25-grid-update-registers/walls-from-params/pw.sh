#!/usr/bin/env bash
# The walls read from the kernel's parameters in the grid update's mirror path (pw, embedded) against
# main's grid update (lean, MPM_PTX_DIR) and d8720a2 (mpm-old); kernel and rank tests; PLY bytes.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm; O=$PWD/.gpu/bin/mpm-old
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/pw
for t in gpu_kernels gpu_ranks; do timeout 200 bash .gpu/run $(ls .gpu/tests/$t-*) > $OUT/pw/$t.log 2>&1; echo "$t rc $?"; grep -E "^test result|FAILED|panicked" $OUT/pw/$t.log; done
(cd /tmp; for b in old new; do bin=$M; [ $b = old ] && bin=$O
  timeout 120 $bin run --backend cuda --scene dam-break --scatter fixed-point --frames 60 --export pw-$b > /dev/null 2>&1 || echo "run $b failed"; done
  diff -rq pw-old pw-new > /dev/null && echo "dam-break fixed point: 61 files byte-identical d8720a2 vs pw" || echo "DIFFER")
b() { timeout 150 "$@" 2>&1 | grep -E "^\| \*\*total|grid_update_blocks" ; }
for args in "--scene bench-65k" "--scene dam-break" "--scene bench-655k" "--scene dam-break --scatter fixed-point" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $args == *16777216* ]] && steps="300 --warmup 100"
  for rep in 1 2; do for v in old lean pw; do echo "== $v $args"
    case $v in old) b $O bench $args --steps $steps;; lean) MPM_PTX_DIR=$PWD/.gpu/ptx-lean b $M bench $args --steps $steps;; pw) b $M bench $args --steps $steps;; esac
  done; done; done > $OUT/pw/bench.txt
grep -E "^== |total\*\*" $OUT/pw/bench.txt | paste - - | awk -F'|' '{split($1,a," "); print a[2], a[3], a[4], $3}' | sort -k2,3 -k1,1 -s
timeout 100 ncu --clock-control none -k regex:"grid_update_blocks" --launch-skip 9 --launch-count 1 --section LaunchStats --section Occupancy --csv $M bench --scene dam-break --steps 20 --warmup 5 > $OUT/pw/ncu-pw.csv 2>&1; echo "pw: $(grep -E 'Registers Per|Achieved Occupancy' $OUT/pw/ncu-pw.csv | awk -F'","' '{print $13" "$15}' | tr '\n' ' ')"
tar czf $OUT/pw.tgz -C $OUT pw
