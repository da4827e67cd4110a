set -u
P=/tmp/p11; mkdir -p $P; tar xJf $PWD/.gpu-pack11/pack.tar.xz -C $P
for f in $P/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
M=$P/mpm; V=$PWD/.gpu-pack11
mkdir -p $OUT
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt
S="--section SpeedOfLight --section Occupancy --section LaunchStats"
for v in L21 L32; do
  MPM_PTX_DIR=$V/ptx-$v ncu --clock-control none -k regex:grid_update_blocks --launch-skip 200 --launch-count 2 $S $M bench --scene dam-break --steps 260 --warmup 10 > $OUT/ncu-$v.txt 2>&1
done
CASES=("--scene dam-break" "--scene bench-65k" "--scene dam-break --scatter fixed-point" "--scene dam-break-obstacle" "--scene bench-655k")
for v in L21 L32; do
  STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab-$v bash scripts/bench-ab.sh $M $M@$V/ptx-$v "${CASES[@]}" > $OUT/ab-$v.txt 2>&1
  STEPS=200 WARMUP=50 RUNS=2 OUT=/tmp/ab16-$v bash scripts/bench-ab.sh $M $M@$V/ptx-$v "--particles 16777216 --grid 256" > $OUT/ab16-$v.txt 2>&1
done
ls -la $OUT
