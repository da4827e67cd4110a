set -u
P=/tmp/p11; mkdir -p $P/t; tar xJf $PWD/.gpu-pack11/pack.tar.xz -C $P; tar xJf $PWD/.gpu-pack11/tests.tar.xz -C $P/t
for f in $P/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
M=$P/mpm; V=$PWD/.gpu-pack11/ptx-U2
export MPM_BIN=$M NCCL_NVLS_ENABLE=0
mkdir -p $OUT
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt
S="--section SpeedOfLight --section Occupancy --section LaunchStats --section WarpStateStats"
MPM_PTX_DIR=$V ncu --clock-control none -k regex:grid_update_blocks --launch-skip 200 --launch-count 2 $S $M bench --scene dam-break --steps 260 --warmup 10 > $OUT/ncu-U2-dam.txt 2>&1
MPM_PTX_DIR=$V ncu --clock-control none -k regex:grid_update_blocks --launch-skip 40 --launch-count 1 $S $M bench --particles 16777216 --grid 256 --steps 60 --warmup 10 > $OUT/ncu-U2-16m.txt 2>&1
CASES=("--scene dam-break" "--scene bench-65k" "--scene dam-break --scatter fixed-point" "--scene dam-break-obstacle" "--scene bench-655k" "--scene dam-break-1m")
STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab-U2 bash scripts/bench-ab.sh $M $M@$V "${CASES[@]}" > $OUT/ab-U2.txt 2>&1
STEPS=200 WARMUP=50 RUNS=2 OUT=/tmp/ab16-U2 bash scripts/bench-ab.sh $M $M@$V "--particles 16777216 --grid 256" > $OUT/ab16-U2.txt 2>&1
cat $OUT/ab-U2.txt $OUT/ab16-U2.txt
for t in gpu_kernels gpu_physics gpu_lifecycle gpu_materials gpu_ranks; do
  MPM_PTX_DIR=$V timeout 200 $P/t/$t* > $OUT/$t.log 2>&1; echo "$t rc=$?" >> $OUT/tests.txt; grep 'test result' $OUT/$t.log >> $OUT/tests.txt
done
cat $OUT/tests.txt
