#!/usr/bin/env bash
# tile_mark_stencil through tile_stencil_block_bits (the working tree) against 5a21a4c's kernels
# (ptx-5a2): substeps of the kernels that mark tiles (one_pass_fixed, p2g_tiled, g2p2g), fixed-point
# bytes, the kernel tests; ncu of one_pass_fixed at bench-655k.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s69
cases=("--scene dam-break --scatter fixed-point" "--scene bench-655k --scatter fixed-point" "--scene bench-65k --scatter fixed-point" "--scene dam-break --pipeline binned" "--scene dam-break --pipeline binned --scatter fixed-point")
OUT=$OUT/s69/ab RUNS=3 bash scripts/bench-ab.sh $M@$G/ptx-5a2 $M "${cases[@]}" 2>&1 | grep "^| \`" | tee $OUT/s69/ab.txt
(cd /tmp; for sc in dam-break fountain; do
  MPM_PTX_DIR=$G/ptx-5a2 timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export h-$sc > /dev/null 2>&1 || echo "5a2 $sc failed"
  timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export n-$sc > /dev/null 2>&1 || echo "new $sc failed"
  diff -rq h-$sc n-$sc > /dev/null && echo "$sc fixed point: $(ls n-$sc | wc -l) PLY files byte-identical, 5a21a4c's kernels vs new" || echo "$sc DIFFER: $(diff -rq h-$sc n-$sc | wc -l)"
done) | tee $OUT/s69/identity.txt
timeout 150 .gpu/tests/gpu_kernels-* 2>&1 | grep -E "^test result|FAILED|panicked" | tee $OUT/s69/tests.txt
timeout 150 ncu --clock-control none --set full -k regex:one_pass_fixed --launch-skip 300 --launch-count 1 -o /tmp/opf $M bench --scene bench-655k --scatter fixed-point --steps 400 --warmup 10 > /tmp/ncu.log 2>&1; echo "ncu rc $?"
ncu -i /tmp/opf.ncu-rep --page source --csv --print-source sass > /tmp/opf-sass.csv 2>&1; python3 scripts/ncu-stalls.py /tmp/opf-sass.csv > $OUT/s69/ncu-one_pass_fixed-stalls.txt 2>&1; head -30 $OUT/s69/ncu-one_pass_fixed-stalls.txt
ncu -i /tmp/opf.ncu-rep --page details 2>&1 | grep -E "one_pass_fixed|Duration|Registers Per|Achieved Occ|Theoretical Occ|Executed Ipc A|Issue Slots Busy|Shared Memory.*Bank|L1/TEX Hit|Memory Throughput|Compute \(SM\) Th|Block Limit" | head -20 | tee $OUT/s69/ncu-details.txt
