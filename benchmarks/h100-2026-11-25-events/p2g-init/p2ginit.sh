#!/usr/bin/env bash
# Fused pipeline: the mirror moved into grid_update, so p2g_init is empty (no event) after the first substep. Old (ce84ccc) vs new.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm; O=$PWD/.gpu/bin/mpm-old
nvidia-smi --query-gpu=name --format=csv,noheader
mkdir -p $OUT/p
(cd /tmp
for b in old new; do bin=$M; [ $b = old ] && bin=$O
  timeout 120 $bin run --backend cuda --scene dam-break --scatter fixed-point --frames 60 --export $b > /dev/null 2>&1; echo "run $b rc $?"; done
diff -rq old new > /dev/null && echo "dam-break fixed point: 61 PLY frames byte-identical old vs new" || echo DIFFER
b() { timeout 100 "$@" 2>&1 | grep -E "^### |^\| " ; }
for args in "--scene bench-65k" "--scene dam-break"; do for bin in $O $M $O $M; do
  echo "== $(basename $bin) $args"; b $bin bench $args --steps 2000
done; done > $OUT/p/bench.txt
grep -E "^== |total" $OUT/p/bench.txt | cut -c1-80)
for t in gpu_bench gpu_kernels gpu_ranks; do timeout 200 bash .gpu/run $(ls .gpu/tests/$t-*) > $OUT/p/$t.log 2>&1; echo "$t rc $?"; grep -E "^test result|FAILED|panicked" $OUT/p/$t.log; done
tar czf $OUT/p2ginit.tgz -C $OUT p
