#!/usr/bin/env bash
# s112: the planes' run sums staged in shared memory instead of shuffled (ptx-st: each lane stores
# its plane's 9 nodes' sums, the lanes of a run share the run's 9 nodes out and sum them over the
# run's lanes in one pass of (node, lane) pairs); ptx-st5: the same at 5 blocks per SM. Against
# fb40f48's kernels (the binary's own).
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
export MPM_BIN=$M PATH=$PATH:/usr/local/cuda/bin
S=$OUT/summary.txt
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $S
bash .gpu/run true
(echo "== head against st"; OUT=/tmp/ab RUNS=2 bash scripts/bench-ab.sh $M $M@$G/ptx-st "--scene dam-break" "--scene bench-655k" "--scene dam-break-1m" 2>&1 | grep "^| \`"
 OUT=/tmp/ab16 RUNS=1 STEPS=300 WARMUP=100 bash scripts/bench-ab.sh $M $M@$G/ptx-st "--particles 16777216 --grid 256" 2>&1 | grep "^| \`"
 echo "== head against st5"; OUT=/tmp/ab5 RUNS=1 bash scripts/bench-ab.sh $M $M@$G/ptx-st5 "--scene dam-break" "--scene bench-655k" "--scene dam-break-1m" 2>&1 | grep "^| \`") | tee -a $S
(cd /tmp; MPM_PTX_DIR=$G/ptx-st timeout 150 compute-sanitizer --tool racecheck --error-exitcode 9 $M run --backend cuda --scene dam-break --frames 2 > /tmp/san.log 2>&1; echo "racecheck st dam break: rc=$? $(grep -E 'RACECHECK SUMMARY' /tmp/san.log)") | tee -a $S
