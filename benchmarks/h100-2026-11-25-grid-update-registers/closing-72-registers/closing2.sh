#!/usr/bin/env bash
# main with the orbit's indices recomputed per channel (72 registers) against d8720a2 (mpm-old):
# the kernel and rank tests, memcheck on the crossing dam break, PLY bytes, the benches twice.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm; O=$PWD/.gpu/bin/mpm-old
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/c2
for t in gpu_kernels gpu_ranks gpu_bench; do timeout 200 bash .gpu/run $(ls .gpu/tests/$t-*) > $OUT/c2/$t.log 2>&1; echo "$t rc $?"; grep -E "^test result|FAILED|panicked" $OUT/c2/$t.log; done
sc=$PWD/.gpu/scenes/dam-break-crossing.toml
for s in float fixed-point; do timeout 200 compute-sanitizer --tool memcheck --error-exitcode 9 $M run --backend cuda --scene $sc --frames 2 --scatter $s > /tmp/san.log 2>&1; echo "memcheck crossing $s: rc=$? $(grep 'ERROR SUMMARY' /tmp/san.log)"; done | tee $OUT/c2/sanitize.txt
(cd /tmp
for sc in dam-break fountain; do for b in old new; do bin=$M; [ $b = old ] && bin=$O
  timeout 120 $bin run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export c2-$b-$sc > /dev/null 2>&1 || echo "run $b $sc failed"; done
  diff -rq c2-old-$sc c2-new-$sc > /dev/null && echo "$sc fixed point: $(ls c2-new-$sc | wc -l) files byte-identical d8720a2 vs main" || echo "$sc DIFFER"; done
b() { timeout 150 "$@" 2>&1 | grep -E "^### |^\| " ; }
for args in "--scene bench-65k" "--scene dam-break" "--scene bench-655k" "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene dam-break-1m" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $args == *16777216* ]] && steps="300 --warmup 100"
  for rep in 1 2; do for bin in $O $M; do echo "== $(basename $bin) $args"; b $bin bench $args --steps $steps; done; done; done > $OUT/c2/bench.txt
grep -E "^== |total\*\*" $OUT/c2/bench.txt | paste - - | awk -F'|' '{print $1, $3}')
tar czf $OUT/closing2.tgz -C $OUT c2
