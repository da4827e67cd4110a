#!/usr/bin/env bash
# grid_update_blocks empties the node-block list itself (no memset node): old (731d673) against new.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm; O=$PWD/.gpu/bin/mpm-old
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/l
(cd /tmp
for scene in dam-break fountain; do
  for b in old new; do bin=$M; [ $b = old ] && bin=$O
    timeout 120 $bin run --backend cuda --scene $scene --scatter fixed-point --frames 60 --export $b-$scene > /dev/null 2>&1; echo "run $b $scene rc $?"
  done
  if diff -rq old-$scene new-$scene > /dev/null; then echo "$scene: fixed point, 61 PLY frames byte-identical old vs new"; else echo "$scene: DIFFER"; fi
done
b() { timeout 100 "$@" 2>&1 | grep -E "^### |\*\*total|grid_update" ; }
for args in "--scene bench-65k" "--scene bench-655k" "--scene dam-break" "--scene bench-65k --pipeline binned"; do for bin in $O $M $O $M; do
  echo "== $(basename $bin) $args"; b $bin bench $args --steps 2000
done; done > $OUT/l/bench.txt
grep -E "^== |total" $OUT/l/bench.txt | cut -c1-80)
for t in gpu_kernels gpu_ranks gpu_lifecycle gpu_physics; do timeout 200 bash .gpu/run $(ls .gpu/tests/$t-*) > $OUT/l/$t.log 2>&1; echo "$t rc $?"; grep -E "^test result" $OUT/l/$t.log; done
tar czf $OUT/listclear.tgz -C $OUT l
