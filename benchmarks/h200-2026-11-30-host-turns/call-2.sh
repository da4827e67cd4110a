#!/usr/bin/env bash
# Session 24 call 2: where the host's time goes per substep (nsys API summary), bench-65k and dam-break.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
export NCCL_NVLS_ENABLE=0 PATH=$PATH:/usr/local/cuda/bin
NSYS=$(command -v nsys || ls /usr/local/cuda*/bin/nsys /opt/nvidia/nsight-systems/*/bin/nsys 2>/dev/null | head -1)
echo "nsys: $NSYS" | tee $OUT/nsys.txt
for s in bench-65k dam-break; do
  timeout 120 $NSYS profile --trace=cuda,nvtx --sample=none --cpuctxsw=none -o /tmp/$s -f true $P/mpm-old bench --scene $s --steps 1000 --warmup 100 > /tmp/$s.log 2>&1
  grep -E "Wall clock|^\| \*\*total" /tmp/$s.log >> $OUT/nsys.txt
  timeout 120 $NSYS stats --report cuda_api_sum,nvtx_sum,cuda_gpu_trace --format csv -o /tmp/st-$s /tmp/$s.nsys-rep > /dev/null 2>&1
  ls /tmp/st-$s* >> $OUT/nsys.txt
  cp /tmp/st-${s}_cuda_api_sum.csv /tmp/st-${s}_nvtx_sum.csv $OUT/ 2>/dev/null
  tail -3000 /tmp/st-${s}_cuda_gpu_trace.csv > $OUT/trace-$s.csv 2>/dev/null
done
head -20 $OUT/st-bench-65k_cuda_api_sum.csv
