#!/usr/bin/env bash
# tile_scatter (tiles.cuh) in the binned pipeline's p2g_tiled and g2p2g too (the working tree) against
# 8373aaf's kernels (ptx-837): substeps; fixed-point bytes run to run and against 8373aaf (the fused
# pipeline's one_pass_fixed has the same instructions: byte-identical expected); the whole suite.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu S=$PWD/.gpu/scripts
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s73
cases=("--scene dam-break --pipeline binned --scatter fixed-point" "--scene bench-655k --pipeline binned --scatter fixed-point" "--scene dam-break --pipeline binned" "--scene bench-65k --pipeline binned" "--scene dam-break --scatter fixed-point")
OUT=$OUT/s73/ab RUNS=2 bash scripts/bench-ab.sh $M@$G/ptx-837 $M "${cases[@]}" 2>&1 | grep "^| \`" | tee $OUT/s73/ab.txt
(cd /tmp; for sc in dam-break fountain; do
  timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export f-$sc > /dev/null 2>&1 || echo "new $sc failed"
  MPM_PTX_DIR=$G/ptx-837 timeout 90 $M run --backend cuda --scene $sc --scatter fixed-point --frames 60 --export h-$sc > /dev/null 2>&1 || echo "837 $sc failed"
  diff -rq h-$sc f-$sc > /dev/null && echo "fused $sc fixed point: $(ls f-$sc | wc -l) PLY files byte-identical, 8373aaf's kernels vs new" || echo "fused $sc DIFFER: $(diff -rq h-$sc f-$sc | wc -l)"
  for r in 1 2; do timeout 90 $M run --backend cuda --scene $sc --pipeline binned --scatter fixed-point --frames 60 --export b$r-$sc > /dev/null 2>&1 || echo "binned $sc $r failed"; done
  diff -rq b1-$sc b2-$sc > /dev/null && echo "binned $sc fixed point: $(ls b1-$sc | wc -l) PLY files byte-identical run to run" || echo "binned $sc DIFFER run to run: $(diff -rq b1-$sc b2-$sc | wc -l)"
  MPM_PTX_DIR=$G/ptx-837 timeout 90 $M run --backend cuda --scene $sc --pipeline binned --scatter fixed-point --frames 60 --export bh-$sc > /dev/null 2>&1 || echo "837 binned $sc failed"
  echo "binned $sc, 8373aaf's kernels against the new:"; python3 $S/plydiff.py bh-$sc b1-$sc
done) | tee $OUT/s73/identity.txt
timeout 300 bash .gpu/tests/all > $OUT/s73/tests.log 2>&1; echo "tests rc $?"
grep -E "^test result" $OUT/s73/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s73/tests.log | head -20
