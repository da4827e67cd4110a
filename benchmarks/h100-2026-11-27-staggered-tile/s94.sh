#!/usr/bin/env bash
# The flush leaving the tile clear, where CUDA blocks take more than one chunk: bench-655k (128-
# particle chunks, more than the launch's 4,224 CUDA blocks) in fixed point, e59034b's kernels
# (ptx-e59) against the binary's own (e52e2e0: 7f195ad's instructions), fused and binned, PLY bytes.
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s94
(cd /tmp; for pl in fused binned; do
  MPM_PTX_DIR=$G/ptx-e59 timeout 100 $M run --backend cuda --scene bench-655k --pipeline $pl --scatter fixed-point --frames 8 --export e-$pl > /tmp/e-$pl.log 2>&1 || echo "e59034b $pl failed: $(tail -2 /tmp/e-$pl.log)"
  timeout 100 $M run --backend cuda --scene bench-655k --pipeline $pl --scatter fixed-point --frames 8 --export n-$pl > /tmp/n-$pl.log 2>&1 || echo "new $pl failed: $(tail -2 /tmp/n-$pl.log)"
  diff -rq e-$pl n-$pl > /dev/null && echo "$pl bench-655k fixed point: $(ls n-$pl | wc -l) PLY files byte-identical, e59034b vs e52e2e0" || echo "$pl DIFFER: $(diff -rq e-$pl n-$pl | wc -l)"
  grep -m1 -i "chunk\|listed" /tmp/n-$pl.log
done) | tee $OUT/s94/identity.txt
