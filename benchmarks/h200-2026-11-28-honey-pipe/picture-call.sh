set -u
P=/tmp/p10; mkdir -p $P; tar xJf $PWD/.gpu-pack10/pack.tar.xz -C $P
for f in $P/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export MPM_BIN=$P/mpm NCCL_NVLS_ENABLE=0
mkdir -p $OUT/r
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/r/gpu.txt
($P/mpm render --scene honey --frames 240 --out /tmp/png --size 960x540 --colour material > $OUT/r/honey-render.log 2>&1) &
$P/gpu_materials --nocapture > $OUT/r/gpu_materials.log 2>&1
wait
cp /tmp/png/frame-00180.png $OUT/honey-180.png; cp /tmp/png/frame-00240.png $OUT/honey-240.png; cp /tmp/png/frame-00150.png $OUT/honey-150.png
ls -la $OUT
