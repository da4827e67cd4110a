#!/usr/bin/env bash
# Session 27 call 1: the tests left unrun (gpu_pbmpm after its helpers moved, gpu_bodies whole) and
# where the position-based substep's time goes kernel by kernel (nsys), at 1M and 10M.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm PATH=$PATH:/usr/local/cuda/bin
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
timeout 150 $P/gpu_pbmpm --nocapture > $L/gpu_pbmpm.log 2>&1 &
timeout 280 $P/gpu_bodies > $L/gpu_bodies.log 2>&1 &
wait
for t in gpu_pbmpm gpu_bodies; do echo "$t: $(grep 'test result' $L/$t.log)"; grep -E "^test .*(FAILED|ignored)" $L/$t.log; done
NSYS=$(command -v nsys || ls /usr/local/cuda*/bin/nsys /opt/nvidia/nsight-systems/*/bin/nsys 2>/dev/null | head -1)
S=.gpu-exp/scenes
for s in pbmpm-1m $S/pb-10m-s8-i1.toml; do
  b=$(basename $s .toml)
  timeout 100 $NSYS profile --trace=cuda,nvtx --sample=none --cpuctxsw=none -o /tmp/$b -f true $P/mpm bench --scene $s --steps 40 --warmup 5 > $L/bench-$b.txt 2>&1
  grep -E "Wall clock|^\| \*\*total" $L/bench-$b.txt
  timeout 100 $NSYS stats --report cuda_gpu_kern_sum,cuda_gpu_mem_time_sum --format csv -o /tmp/st-$b /tmp/$b.nsys-rep > /dev/null 2>&1
  cp /tmp/st-${b}_*.csv $L/ 2>/dev/null
  head -14 /tmp/st-${b}_cuda_gpu_kern_sum.csv | cut -d, -f1-4,9 
done
tar -czf $OUT/logs.tgz -C /tmp logs
