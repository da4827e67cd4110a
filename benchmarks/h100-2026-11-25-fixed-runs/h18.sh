#!/usr/bin/env bash
# Issue 18, fixed-point scatter by integer warp runs: old (main before) against new, one device call.
export NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm; O=$PWD/.gpu/bin/mpm-old
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/h; cd /tmp
for scene in dam-break fountain; do
  for b in old new; do bin=$M; [ $b = old ] && bin=$O
    timeout 120 $bin run --backend cuda --scene $scene --scatter fixed-point --frames 60 --export $b-$scene > $OUT/h/run-$b-$scene.log 2>&1; echo "run $b $scene rc $?"
  done
  if diff -rq old-$scene new-$scene > /dev/null; then echo "$scene: fixed point, 61 PLY frames byte-identical old vs new"; else echo "$scene: DIFFER"; diff -rq old-$scene new-$scene | head -3; fi
done
b() { timeout 100 "$@" 2>&1 | grep -E "^### |\*\*total|one_pass" ; }
for scene in bench-655k bench-65k dam-break; do for mode in float fixed-point; do for bin in $O $M; do
  echo "== $(basename $bin) $scene $mode"; b $bin bench --scene $scene --scatter $mode --steps 2000
done; done; done > $OUT/h/bench.txt
for mode in float fixed-point; do for bin in $O $M; do
  echo "== $(basename $bin) 16.8M $mode"; b $bin bench --particles 16777216 --grid 256 --scatter $mode --steps 300 --warmup 100
done; done >> $OUT/h/bench.txt
grep -E "^== |total" $OUT/h/bench.txt | cut -c1-70
cd - > /dev/null
t=$(ls .gpu/tests/gpu_kernels-*)
timeout 150 compute-sanitizer --tool memcheck --error-exitcode 9 $t fixed_point_is_byte_identical --test-threads 1 > $OUT/h/san-memcheck.log 2>&1; echo "memcheck rc $?"; tail -2 $OUT/h/san-memcheck.log
timeout 150 compute-sanitizer --tool racecheck --error-exitcode 9 $t fixed_point_overflow_is_reported --test-threads 1 > $OUT/h/san-racecheck.log 2>&1; echo "racecheck rc $?"; tail -2 $OUT/h/san-racecheck.log
tar czf $OUT/h18.tgz -C $OUT h
