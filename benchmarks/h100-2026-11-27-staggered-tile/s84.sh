#!/usr/bin/env bash
# The tile's stencil staggered by lane (lane mod 9 chooses where its x and y rows start), so lanes
# of one cell add to different nodes at each step: 3ad7f00's kernels (ptx-head) against the
# staggered ones (the binary's own); fixed-point bytes; ncu shared-atomic conflicts; dam-break-1m's
# phases (float) for the plan.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s84
cases=("--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break-1m --scatter fixed-point" "--scene dam-break --pipeline binned --scatter fixed-point" "--scene dam-break --pipeline binned")
(echo "== 3ad7f00 (ptx-head) against staggered"; OUT=$OUT/s84/ab RUNS=2 bash scripts/bench-ab.sh $M@$G/ptx-head $M "${cases[@]}" 2>&1 | grep "^| \`"
 echo "== 16.8M fixed"; OUT=$OUT/s84/ab16 RUNS=1 STEPS=300 WARMUP=100 bash scripts/bench-ab.sh $M@$G/ptx-head $M "--particles 16777216 --grid 256 --scatter fixed-point" 2>&1 | grep "^| \`") | tee $OUT/s84/ab.txt
(cd /tmp; for sc in dam-break fountain; do for pl in fused binned; do
  timeout 90 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 60 --export n-$pl-$sc > /dev/null 2>&1 || echo "new $pl $sc failed"
  MPM_PTX_DIR=$G/ptx-head timeout 90 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 60 --export h-$pl-$sc > /dev/null 2>&1 || echo "head $pl $sc failed"
  diff -rq h-$pl-$sc n-$pl-$sc > /dev/null && echo "$pl $sc fixed point: $(ls n-$pl-$sc | wc -l) PLY files byte-identical, 3ad7f00's kernels vs staggered" || echo "$pl $sc DIFFER: $(diff -rq h-$pl-$sc n-$pl-$sc | wc -l)"
done; done) | tee $OUT/s84/identity.txt
MET=gpu__time_duration.sum,smsp__inst_executed_op_shared_atom.sum,l1tex__data_bank_conflicts_pipe_lsu_mem_shared_op_atom.sum,l1tex__data_pipe_lsu_wavefronts_mem_shared_op_atom.sum,smsp__inst_executed.sum
for side in head new; do
  if [ $side = head ]; then export MPM_PTX_DIR=$G/ptx-head; else unset MPM_PTX_DIR; fi
  timeout 120 ncu --clock-control none --metrics $MET -k regex:one_pass_fixed --launch-skip 300 --launch-count 3 $M bench --scene dam-break --scatter fixed-point --steps 400 --warmup 10 2>&1 | grep -E "one_pass_fixed|gpu__|smsp__|l1tex__" | sed "s/^/$side /"
done | tee $OUT/s84/ncu.txt
unset MPM_PTX_DIR
timeout 60 $M bench --scene dam-break-1m --steps 600 --warmup 100 2>&1 | tail -30 > $OUT/s84/phases-1m.txt
(timeout 240 .gpu/tests/gpu_kernels-* 2>&1 | grep -E "^test result|FAILED|panicked") | tee $OUT/s84/tests.txt
