#!/usr/bin/env bash
# Call 3: the benches of call 2 again (there an empty MPM_ONE_PASS_BLOCKS_PER_SM made head, skip and new panic).
export NCCL_NVLS_ENABLE=0
M=$PWD/.gpu/bin/mpm
mkdir -p $OUT/s3
run_v() { local v=$1; shift; local d=/nonexistent
  case $v in head) d=$PWD/.gpu/ptx-head;; skip) d=$PWD/.gpu/ptx-skip;; esac
  case $v in new6) export MPM_ONE_PASS_BLOCKS_PER_SM=6;; new12) export MPM_ONE_PASS_BLOCKS_PER_SM=12;; *) unset MPM_ONE_PASS_BLOCKS_PER_SM;; esac
  MPM_PTX_DIR=$d timeout 90 $M "$@"; }
for sc in "--scene dam-break" "--scene bench-655k" "--scene bench-65k" "--scene dam-break --scatter fixed-point" "--scene dam-break-1m" "--particles 16777216 --grid 256"; do
  steps=2000; vs="head skip new new12"; [[ $sc == *16777216* ]] && { steps="300 --warmup 100"; vs="head new new12"; }
  [[ $sc == *fixed* ]] && vs="head skip new"
  for r in 1 2; do for v in $vs; do
    echo "== $v $sc"; run_v $v bench $sc --steps $steps 2>&1 | grep -E "one_pass \(|total|rror|panic"
done; done; done > $OUT/s3/bench.txt 2>&1
