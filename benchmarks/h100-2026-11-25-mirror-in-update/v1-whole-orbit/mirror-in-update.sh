#!/usr/bin/env bash
# The fused pipeline's mirror inside grid_update_blocks (no mirror_walls launch). Old (d8720a2) vs new.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm; O=$PWD/.gpu/bin/mpm-old
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/m
for t in gpu_kernels gpu_ranks; do timeout 200 bash .gpu/run $(ls .gpu/tests/$t-*) > $OUT/m/$t.log 2>&1; echo "$t rc $?"; grep -E "^test result|FAILED|panicked" $OUT/m/$t.log; done
grep -E "tank (FixedPoint|Float), substep" $OUT/m/gpu_kernels.log
(cd /tmp
for sc in dam-break fountain drop; do for b in old new; do bin=$M; [ $b = old ] && bin=$O
  timeout 120 $bin run --backend cuda --scene $sc --scatter fixed-point --frames 40 --export $b-$sc > /dev/null 2>&1 || echo "run $b $sc failed"; done
diff -rq old-$sc new-$sc > /dev/null && echo "$sc fixed point: $(ls new-$sc | wc -l) files byte-identical old vs new" || echo "$sc DIFFER"; done
timeout 120 $M run --backend cuda --scene dam-break --scatter fixed-point --frames 40 --ranks 2 --export ranks2 > /dev/null 2>&1
diff -rq old-dam-break ranks2 > /dev/null && echo "dam-break --ranks 2 fixed point: byte-identical to old one rank" || echo "ranks2 DIFFER"
b() { timeout 100 "$@" 2>&1 | grep -E "^### |^\| " ; }
for args in "--scene bench-65k" "--scene dam-break" "--scene bench-655k" "--scene dam-break --scatter fixed-point" "--scene bench-65k --pipeline binned"; do for bin in $O $M $O $M; do
  echo "== $(basename $bin) $args"; b $bin bench $args --steps 2000
done; done > $OUT/m/bench.txt
grep -E "^== |^\| total|^\| grid_update|^\| p2g_init|^\| g2p " $OUT/m/bench.txt | cut -c1-100)
which ncu >/dev/null && timeout 120 ncu --clock-control none -k regex:"grid_update_blocks|mirror_walls|clear_crossing" --launch-skip 20 --launch-count 6 --section LaunchStats --section SpeedOfLight --csv $M bench --scene dam-break --steps 30 --warmup 10 > $OUT/m/ncu.csv 2>&1; grep -E "Registers Per|Duration" $OUT/m/ncu.csv | cut -c1-200 | head -20
tar czf $OUT/mirror.tgz -C $OUT m
