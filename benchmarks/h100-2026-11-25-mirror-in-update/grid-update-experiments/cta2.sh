#!/usr/bin/env bash
# grid_update_blocks: v1 (barrier every iteration) and v3 (barrier only where a node block meets a
# wall), 1 and 2 node blocks per CUDA block, against main (mpm-old).
export NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm; O=$PWD/.gpu/bin/mpm-old
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/cta2
b() { timeout 100 "$@" 2>&1 | grep -E "^\| \*\*total|grid_update_blocks" ; }
for args in "--scene bench-65k" "--scene dam-break" "--scene bench-655k" "--scene dam-break --scatter fixed-point" "--particles 16777216 --grid 256"; do
  steps=2000; [[ $args == *16777216* ]] && steps="300 --warmup 100"
  for rep in 1 2; do for v in old v1-1 v1-2 v3-1 v3-2; do
  echo "== $v $args"; if [ $v = old ]; then b $O bench $args --steps $steps; else MPM_PTX_DIR=$PWD/.gpu/ptx-${v%-*} MPM_GU_PER_CTA=${v#*-} b $M bench $args --steps $steps; fi
done; done; done > $OUT/cta2/bench.txt
grep -E "^== |total" $OUT/cta2/bench.txt | cut -c1-60 | paste - -
grep -E "^== |grid_update" $OUT/cta2/bench.txt | cut -c1-90 | paste - - | sed 's/grid_update_blocks (+ mirror mass and momentum)//' | head -60
(cd /tmp; for v in old 2; do bin=$M; [ $v = old ] && bin=$O
  MPM_PTX_DIR=$PWD/.gpu/ptx-v3 MPM_GU_PER_CTA=$v timeout 120 $bin run --backend cuda --scene dam-break --scatter fixed-point --frames 30 --export cta-$v > /dev/null 2>&1 || echo "run $v failed"; done
diff -rq cta-old cta-2 > /dev/null && echo "dam-break fixed point: v3 per_cta 2 byte-identical to main" || echo DIFFER)
MPM_PTX_DIR=$PWD/.gpu/ptx-v3 MPM_GU_PER_CTA=2 timeout 200 bash .gpu/run $(ls .gpu/tests/gpu_kernels-*) > $OUT/cta2/gpu_kernels.log 2>&1; echo "gpu_kernels (v3, per_cta 2) rc $?"; grep -E "^test result" $OUT/cta2/gpu_kernels.log
tar czf $OUT/cta2.tgz -C $OUT cta2
