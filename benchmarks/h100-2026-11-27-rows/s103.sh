#!/usr/bin/env bash
# s103: one_pass with fewer instructions a particle, against 767bb73's kernels (ptx-a), one binary:
#   ptx-c: the impulse's affine product summed z, y, x (plane and row terms once), and dead lanes
#          zeroed once instead of 108 selects;
#   mpm (embedded, "B"): ptx-c plus the gather summed a stencil row at a time.
# Then the kernel and physics tests on B (the CPU oracle), fixed-point bytes run to run on B, and
# count_layers' grid-stride launch (mpm-cl, branch next/count-layers-grid-stride) against mpm,
# both on 767bb73's kernels.
M=$PWD/.gpu/bin/mpm CL=$PWD/.gpu/bin/mpm-cl G=$PWD/.gpu
export MPM_BIN=$M NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
S=$OUT/summary.txt
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $S
bash .gpu/run true
cases=("--scene dam-break" "--scene bench-655k" "--scene dam-break-1m" "--scene bench-65k" "--scene fountain" "--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene dam-break --pipeline binned")
(echo "== A (767bb73) against B"; OUT=/tmp/ab RUNS=2 bash scripts/bench-ab.sh $M@$G/ptx-a $M "${cases[@]}" 2>&1 | grep "^| \`") | tee -a $S
(echo "== 16.8M: A against B"; OUT=/tmp/ab16 RUNS=1 STEPS=300 WARMUP=100 bash scripts/bench-ab.sh $M@$G/ptx-a $M "--particles 16777216 --grid 256" 2>&1 | grep "^| \`") | tee -a $S
(echo "== A against C"; OUT=/tmp/ac RUNS=1 bash scripts/bench-ab.sh $M@$G/ptx-a $M@$G/ptx-c "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break --scatter fixed-point" 2>&1 | grep "^| \`") | tee -a $S
for t in gpu_kernels gpu_physics walls colliders flow; do
  x=$(ls $G/tests/$t-*); timeout 150 $x > /tmp/$t.log 2>&1; echo "$t rc $? $(grep 'test result' /tmp/$t.log)" >> $S
  grep -E "panicked|FAILED|not run" /tmp/$t.log | head -8 >> $S
done
cat /tmp/gpu_kernels.log /tmp/gpu_physics.log > $OUT/tests.log
(cd /tmp; for r in 1 2; do for sc in dam-break fountain; do
  timeout 60 $M run --backend cuda --scene $sc --scatter fixed-point --frames 40 --export b$r-$sc > /dev/null 2>&1 || echo "$sc $r failed"; done; done
 for sc in dam-break fountain; do diff -rq b1-$sc b2-$sc > /dev/null && echo "$sc fixed point on B: $(ls b2-$sc | wc -l) PLY files byte-identical run to run" || echo "$sc DIFFERS run to run"; done) >> $S
(cd /tmp; for b in mpm mpm-cl; do
  timeout 120 ncu --clock-control none --kernel-name count_layers --launch-count 4 --metrics gpu__time_duration.sum --csv $G/bin/$b bench --particles 16777216 --grid 256 --ranks 2 --steps 40 --warmup 10 2>/dev/null | grep count_layers | awk -F'","' -v b=$b '{print b, $5, $NF}' | tr -d '"' ; done) >> $S
for r in 1 2; do for b in mpm mpm-cl; do
  MPM_PTX_DIR=$G/ptx-a timeout 100 $G/bin/$b bench --backend cuda --particles 16777216 --grid 256 --ranks 2 --steps 300 --warmup 50 > /tmp/r-$b.txt 2>&1; echo "== ranks 2 16.8M $b rc $?" >> $S; grep -E "total|count|migrat" /tmp/r-$b.txt | cut -c1-160 >> $S
done; done
cat $S
