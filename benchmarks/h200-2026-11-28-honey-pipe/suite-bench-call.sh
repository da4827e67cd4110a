set -u
P=$PWD/.gpu-pack9
rm -rf .gpu; mkdir -p .gpu && tar xJf $P/pack.tar.xz -C .gpu
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0
for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
mkdir -p $OUT/r /tmp/w
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/r/gpu.txt
A=$PWD/.gpu/bin/mpm B=$P/before-mpm
STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab bash scripts/bench-ab.sh $B $A "--scene bench-655k" "--scene dam-break" "--scene dam-break-obstacle" > $OUT/r/ab.txt 2>&1
$A run --scene honey --frames 120 --backend cuda > $OUT/r/honey-run.log 2>&1
(bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --out /tmp/g --timeout 300 > $OUT/r/gpu-tests.log 2>&1) &
($A render --scene honey --frames 240 --out /tmp/png --size 960x540 --colour material > $OUT/r/honey-render.log 2>&1) &
(cd /tmp/w && $A run --scene $P/trouton5.toml --frames 60 --backend cuda --export t5 --every 60 > $OUT/r/t5.log 2>&1 && python3 $P/trouton.py t5/frame_000060.ply 0.005 0.25 > $OUT/r/t5.txt 2>&1;
 $A run --scene $P/trouton25.toml --frames 60 --backend cuda --export t25 --every 60 > $OUT/r/t25.log 2>&1 && python3 $P/trouton.py t25/frame_000060.ply 0.0025 0.25 > $OUT/r/t25.txt 2>&1) &
wait
mkdir -p /tmp/keep; for n in 00060 00120 00180 00240; do cp /tmp/png/frame-$n.png /tmp/keep/ 2>/dev/null; done
cd /tmp/keep && tar cf $OUT/png.tar .
cp -r /tmp/g $OUT/r/g 2>/dev/null; cd $OUT && tar cf logs.tar r; ls -la $OUT /tmp/keep
