#!/usr/bin/env bash
# Where the CUDA thickness pass's time goes: the kernels' own durations (ncu), and an nsys trace summary.
export MPM_BIN=$PWD/.gpu/bin/mpm PATH=$PATH:/usr/local/cuda/bin
M=$PWD/.gpu/bin/mpm
bash .gpu/run true
ls /usr/local/cuda/bin | grep -E "nsys|ncu" ; which nsys ncu
for size in 1920x1080 960x540; do
  echo "== ncu $size"
  timeout 200 ncu --clock-control none -k regex:"splat_thickness|resolve_thickness" -c 6 --metrics gpu__time_duration.sum,sm__throughput.avg.pct_of_peak_sustained_elapsed,lts__t_sectors_op_red.sum,l1tex__t_set_conflicts_pipe_lsu_mem_global_op_red.sum $M render --scene dam-break --frames 6 --size $size --backend cuda --draw surface --no-images 2>&1 | grep -E "splat_thickness|resolve_thickness|gpu__time|throughput|lts__|conflicts" | head -24
done
NSYS=$(ls /usr/local/cuda/bin/nsys /opt/nvidia/nsight-systems/*/bin/nsys 2>/dev/null | head -1)
if [ -n "$NSYS" ]; then
  timeout 200 $NSYS profile --trace=cuda,opengl,nvtx,osrt -o /tmp/r --force-overwrite true $M render --scene dam-break --frames 30 --size 1920x1080 --backend cuda --draw surface --no-images > /dev/null 2>&1
  timeout 100 $NSYS stats --report cuda_api_sum,cuda_gpu_kern_sum,openglapi_sum --format csv /tmp/r.nsys-rep 2>&1 | grep -iE "Graphics|TexSubImage|Finish|Flush|thickness|render_attr|Name|MapRes|Unmap|SwapBuffers|Memcpy" | head -40
fi
