set -u
P=/tmp/p11; mkdir -p $P/t; tar xJf $PWD/.gpu-pack11/pack.tar.xz -C $P; tar xJf $PWD/.gpu-pack11/tests.tar.xz -C $P/t
for f in $P/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
M=$P/mpm
export MPM_BIN=$M NCCL_NVLS_ENABLE=0
mkdir -p $OUT
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt
CASES=("--scene dam-break" "--scene bench-65k" "--scene dam-break --scatter fixed-point" "--scene bench-655k" "--scene dam-break-1m")
for v in U2b U2c; do
  V=$PWD/.gpu-pack11/ptx-$v
  MPM_PTX_DIR=$V ncu --clock-control none -k regex:grid_update_blocks --launch-skip 200 --launch-count 1 --section LaunchStats --section Occupancy $M bench --scene dam-break --steps 230 --warmup 10 2>&1 | grep -E 'Registers Per|Achieved Occ|Duration' > $OUT/ncu-$v.txt
  STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab-$v bash scripts/bench-ab.sh $M $M@$V "${CASES[@]}" > $OUT/ab-$v.txt 2>&1
  STEPS=200 WARMUP=50 RUNS=2 OUT=/tmp/ab16-$v bash scripts/bench-ab.sh $M $M@$V "--particles 16777216 --grid 256" > $OUT/ab16-$v.txt 2>&1
  for t in gpu_kernels gpu_lifecycle; do
    MPM_PTX_DIR=$V timeout 120 $P/t/$t* > /tmp/$t-$v.log 2>&1; echo "$v $t rc=$? $(grep 'test result' /tmp/$t-$v.log)" >> $OUT/tests.txt
  done
done
cd $OUT; for v in U2b U2c; do echo "== $v"; cat ncu-$v.txt; grep '^|' ab-$v.txt ab16-$v.txt; done; cat tests.txt
