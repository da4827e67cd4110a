#!/usr/bin/env bash
# The tile's stencil staggered on all three axes (lane mod 27, ptx-xyz) against x and y (lane mod 9,
# e59034b, the binary's own kernels); fixed-point bytes; ncu conflicts.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s85
cases=("--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break-1m --scatter fixed-point" "--scene fountain --scatter fixed-point" "--scene dam-break --pipeline binned --scatter fixed-point")
(echo "== e59034b (xy) against ptx-xyz"; OUT=$OUT/s85/ab RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-xyz "${cases[@]}" 2>&1 | grep "^| \`"
 echo "== 16.8M fixed"; OUT=$OUT/s85/ab16 RUNS=1 STEPS=300 WARMUP=100 bash scripts/bench-ab.sh $M $M@$G/ptx-xyz "--particles 16777216 --grid 256 --scatter fixed-point" 2>&1 | grep "^| \`") | tee $OUT/s85/ab.txt
(cd /tmp; for sc in dam-break fountain; do for pl in fused binned; do
  [ -d h-$pl-$sc ] || MPM_PTX_DIR=$G/ptx-head timeout 90 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 60 --export h-$pl-$sc > /dev/null 2>&1
  MPM_PTX_DIR=$G/ptx-xyz timeout 90 $M run --backend cuda --scene $sc --pipeline $pl --scatter fixed-point --frames 60 --export z-$pl-$sc > /dev/null 2>&1 || echo "xyz $pl $sc failed"
  diff -rq h-$pl-$sc z-$pl-$sc > /dev/null && echo "$pl $sc fixed point: $(ls z-$pl-$sc | wc -l) PLY files byte-identical, 3ad7f00's kernels (s84) vs xyz" || echo "$pl $sc DIFFER: $(diff -rq h-$pl-$sc z-$pl-$sc | wc -l)"
done; done) | tee $OUT/s85/identity.txt
MET=gpu__time_duration.sum,smsp__inst_executed_op_shared_atom.sum,l1tex__data_bank_conflicts_pipe_lsu_mem_shared_op_atom.sum,l1tex__data_pipe_lsu_wavefronts_mem_shared_op_atom.sum,smsp__inst_executed.sum
for side in xy xyz; do
  if [ $side = xyz ]; then export MPM_PTX_DIR=$G/ptx-xyz; else unset MPM_PTX_DIR; fi
  for sc in dam-break bench-655k; do
  timeout 120 ncu --clock-control none --metrics $MET -k regex:one_pass_fixed --launch-skip 300 --launch-count 2 $M bench --scene $sc --scatter fixed-point --steps 400 --warmup 10 2>&1 | grep -E "gpu__|smsp__|l1tex__" | sed "s/^/$side $sc /"
  done
done | tee $OUT/s85/ncu.txt
