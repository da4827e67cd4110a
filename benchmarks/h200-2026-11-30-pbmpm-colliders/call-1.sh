#!/usr/bin/env bash
# Session 26 call 1: f5d3c8b's mpm (mpm-old) against this build on bench-65k (explicit water) and
# pbmpm-1m, then the GPU tests the change touches, in parallel: gpu_pbmpm (colliders under pbmpm),
# gpu_kernels, gpu_render (HeadlessGl's release), gpu_lifecycle, gpu_bodies, gpu_materials (the
# launches' optional arguments).
set -u
P=/tmp/p; rm -rf $P; mkdir -p $P && tar -xJf .gpu-exp/pack.tar.xz -C $P --strip-components=1
for f in .gpu-exp/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0 MPM_BIN=$P/mpm
L=/tmp/logs; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
for round in 1 2; do
  for b in mpm-old mpm; do
    timeout 60 $P/$b bench --scene bench-65k --steps 1000 --warmup 100 > $L/bench-65k-$b-$round.txt 2>&1
    timeout 60 $P/$b bench --scene pbmpm-1m --steps 40 --warmup 5 > $L/pbmpm-1m-$b-$round.txt 2>&1
  done
done
grep -H -E "ms/step|per step|ms a|median" $L/bench-*.txt $L/pbmpm-*.txt | head -40
for t in gpu_pbmpm gpu_kernels gpu_render gpu_lifecycle gpu_bodies gpu_materials; do
  timeout 220 $P/$t --nocapture > $L/$t.log 2>&1 &
done
wait
for t in gpu_pbmpm gpu_kernels gpu_render gpu_lifecycle gpu_bodies gpu_materials; do echo "$t: $(grep 'test result' $L/$t.log)"; done
grep -h "RESULT pbmpm GPU.*\(Coulomb\|crushed\|among\|platform\)" $L/gpu_pbmpm.log | head -20
tar -czf $OUT/logs.tgz -C /tmp logs
