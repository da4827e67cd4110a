#!/usr/bin/env bash
# Where the two-GPU substep's time goes: nsys over the 33.5M column on --gpus 2 (kernel time per
# device: one_pass, count_strays, the halo kernels and NCCL's), the 16.8M column on one GPU beside
# it; then compute-sanitizer memcheck of the two-GPU fixed-point test (the peer writes).
M=$PWD/.gpu/bin/mpm G=$PWD/.gpu
export MPM_BIN=$M NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
S=$OUT/summary.txt
bash .gpu/run true
NSYS=$(command -v nsys || ls /usr/local/cuda*/bin/nsys /opt/nvidia/nsight-systems/*/bin/nsys 2>/dev/null | head -1)
echo "nsys: $NSYS" > $S
cd /tmp
for c in "c33-2 --particles 33554432 --gpus 2" "c16-1 --particles 16777216"; do
  set -- $c; name=$1; shift
  timeout 150 $NSYS profile -t cuda,nvtx -o /tmp/$name --force-overwrite true $M bench --backend cuda "$@" --grid 256 --steps 300 --warmup 50 > /tmp/$name.txt 2>&1; echo "== $name nsys rc $?" >> $S
  grep -E "Wall clock|total|halo|one_pass" /tmp/$name.txt | head -6 >> $S
  timeout 120 $NSYS export --type sqlite -o /tmp/$name.sqlite --force-overwrite true /tmp/$name.nsys-rep > /dev/null 2>&1
  python3 $G/scripts/kern-by-device.py /tmp/$name.sqlite 350 >> $S 2>&1
done
cd $G/..
t2=$(ls $G/tests/gpu_ranks_on_gpus-*)
timeout 200 compute-sanitizer --tool memcheck --print-limit 20 $t2 two_gpus_gives --test-threads 1 > $OUT/memcheck.log 2>&1; echo "memcheck rc $?" >> $S
grep -E "ERROR SUMMARY|test result|Invalid" $OUT/memcheck.log | head -10 >> $S
