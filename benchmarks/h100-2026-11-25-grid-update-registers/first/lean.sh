#!/usr/bin/env bash
# grid_update_blocks: main (head) vs lean (orbit indices recomputed per channel) vs lean2 (and the
# walls recomputed per node block). One binary, MPM_PTX_DIR.
export NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/lean
b() { timeout 100 "$@" 2>&1 | grep -E "^\| \*\*total|grid_update_blocks" ; }
for args in "--scene bench-65k" "--scene dam-break" "--scene bench-655k" "--scene dam-break --scatter fixed-point" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $args == *16777216* ]] && steps="300 --warmup 100"
  for rep in 1 2; do for v in head lean lean2; do
  echo "== $v $args"; MPM_PTX_DIR=$PWD/.gpu/ptx-$v b $M bench $args --steps $steps
done; done; done > $OUT/lean/bench.txt
grep -E "^== |total\*\*" $OUT/lean/bench.txt | paste - - | awk -F'|' '{split($1,a," "); print a[2], a[3], a[4], $3}' | sort -k2,3 -k1,1 -s
for v in head lean lean2; do MPM_PTX_DIR=$PWD/.gpu/ptx-$v timeout 100 ncu --clock-control none -k regex:"grid_update_blocks" --launch-skip 9 --launch-count 1 --section LaunchStats --section Occupancy --csv $M bench --scene dam-break --steps 20 --warmup 5 > $OUT/lean/ncu-$v.csv 2>&1; echo "$v: $(grep -E 'Registers Per|Achieved Occupancy' $OUT/lean/ncu-$v.csv | awk -F'","' '{print $13" "$15}' | tr '\n' ' ')"; done
(cd /tmp; for v in head lean2; do MPM_PTX_DIR=$OLDPWD/.gpu/ptx-$v timeout 120 $M run --backend cuda --scene dam-break --scatter fixed-point --frames 30 --export lean-$v > /dev/null 2>&1 || echo "run $v failed"; done
diff -rq lean-head lean-lean2 > /dev/null && echo "dam-break fixed point: lean2 byte-identical to head" || echo DIFFER)
tar czf $OUT/lean.tgz -C $OUT lean
