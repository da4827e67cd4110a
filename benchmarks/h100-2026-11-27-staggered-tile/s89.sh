#!/usr/bin/env bash
# Two load-chain variants against e59034b (the binary's own kernels): grid_update_blocks loading its
# next list entry before the list's length says it is listed (ptx-gupf), one_pass loading its next
# bin entry during the current chunk (ptx-binpf). Then e59034b's checks: the whole suite, memcheck and
# racecheck of the staggered tile.
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
bash .gpu/run true
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p $OUT/s89
cases=("--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break-1m" "--scene fountain" "--scene dam-break --scatter fixed-point" "--scene dam-break --pipeline binned")
(for v in gupf binpf; do echo "== e59034b against ptx-$v"; OUT=$OUT/s89/$v RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-$v "${cases[@]}" 2>&1 | grep "^| \`"; done) | tee $OUT/s89/ab.txt
(cd /tmp; for pl in fused binned; do timeout 120 compute-sanitizer --tool memcheck --error-exitcode 9 $M run --backend cuda --scene dam-break --pipeline $pl --scatter fixed-point --frames 2 > /tmp/san.log 2>&1; echo "memcheck $pl fixed dam break: rc=$? $(grep -E 'ERROR SUMMARY' /tmp/san.log)"; done
 timeout 150 compute-sanitizer --tool racecheck --error-exitcode 9 $M run --backend cuda --scene dam-break --pipeline fused --scatter fixed-point --frames 2 > /tmp/san.log 2>&1; echo "racecheck fused fixed dam break: rc=$? $(grep -E 'RACECHECK SUMMARY' /tmp/san.log)"
 timeout 150 compute-sanitizer --tool racecheck --error-exitcode 9 $M run --backend cuda --scene fountain --pipeline binned --scatter fixed-point --frames 2 > /tmp/san.log 2>&1; echo "racecheck binned fixed fountain: rc=$? $(grep -E 'RACECHECK SUMMARY' /tmp/san.log)") | tee $OUT/s89/sanitize.txt
timeout 330 bash .gpu/tests/all > $OUT/s89/tests.log 2>&1; echo "tests rc $?"
(grep -E "^test result" $OUT/s89/tests.log | awk '{p+=$4; f+=$6; i+=$8} END {print p" passed, "f" failed, "i" ignored"}'
grep -E "FAILED|panicked|^not run" $OUT/s89/tests.log | head -20) | tee $OUT/s89/tests-summary.txt
