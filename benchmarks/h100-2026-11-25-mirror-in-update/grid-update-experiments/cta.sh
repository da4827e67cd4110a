#!/usr/bin/env bash
# grid_update_blocks with 1, 2, 4 node blocks per CUDA block (MPM_GU_PER_CTA), against main (mpm-old).
export NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm; O=$PWD/.gpu/bin/mpm-old
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/cta
b() { timeout 100 "$@" 2>&1 | grep -E "^\| \*\*total|grid_update_blocks" ; }
for args in "--scene bench-65k" "--scene dam-break" "--scene bench-655k" "--scene dam-break --scatter fixed-point" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $args == *16777216* ]] && steps="300 --warmup 100"
  for rep in 1 2; do for v in old 1 2 4; do
  echo "== $v $args"; if [ $v = old ]; then b $O bench $args --steps $steps; else MPM_GU_PER_CTA=$v b $M bench $args --steps $steps; fi
done; done; done > $OUT/cta/bench.txt
grep -E "^== |total" $OUT/cta/bench.txt | cut -c1-60 | paste - -
grep -E "^== |grid_update" $OUT/cta/bench.txt | cut -c1-90 | paste - - | head -40
(cd /tmp; for v in old 4; do bin=$M; [ $v = old ] && bin=$O
  MPM_GU_PER_CTA=$v timeout 120 $bin run --backend cuda --scene dam-break --scatter fixed-point --frames 30 --export cta-$v > /dev/null 2>&1 || echo "run $v failed"; done
diff -rq cta-old cta-4 > /dev/null && echo "dam-break fixed point: per_cta 4 byte-identical to main" || echo DIFFER)
MPM_GU_PER_CTA=4 timeout 200 bash .gpu/run $(ls .gpu/tests/gpu_kernels-*) > $OUT/cta/gpu_kernels.log 2>&1; echo "gpu_kernels (per_cta 4) rc $?"; grep -E "^test result" $OUT/cta/gpu_kernels.log
tar czf $OUT/cta.tgz -C $OUT cta
