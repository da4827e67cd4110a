#!/usr/bin/env bash
# Session 28 call 5: the final build: gpu_pbmpm (with the preset's 5 s run), headless frames of the
# new pbmpm-1m (8 x 2) and dam-break-1m at 960x540, two rounds each.
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
timeout 240 $P/gpu_pbmpm --nocapture > $L/gpu_pbmpm.log 2>&1
echo "gpu_pbmpm: $(grep 'test result' $L/gpu_pbmpm.log)"; grep -E "^test .*(FAILED|ignored)|panicked|RESULT pbmpm GPU pbmpm-1m" $L/gpu_pbmpm.log | head
for r in 1 2; do for s in pbmpm-1m dam-break-1m; do
  timeout 60 $P/mpm render --backend cuda --scene $s --size 960x540 --frames 90 --no-images > $L/render-$s-$r.txt 2>&1; echo "== render $s round $r: $(grep 'frames via' $L/render-$s-$r.txt)"
done; done
tail -3 $L/render-pbmpm-1m-1.txt
tar -czf $OUT/logs.tgz -C /tmp logs
