set -u
P=/tmp/p11; mkdir -p $P/t; tar xJf $PWD/.gpu-pack11/pack.tar.xz -C $P; tar xJf $PWD/.gpu-pack11/tests.tar.xz -C $P/t
for f in $P/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
M=$P/mpm; V=$PWD/.gpu-pack11/ptx-U2d
export MPM_BIN=$M NCCL_NVLS_ENABLE=0
mkdir -p $OUT
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt
STEPS=1000 WARMUP=100 RUNS=2 OUT=/tmp/ab bash scripts/bench-ab.sh $M $M@$V "--scene dam-break" "--scene bench-65k" "--scene dam-break --scatter fixed-point" "--scene dam-break-1m" > $OUT/ab-U2d.txt 2>&1
STEPS=200 WARMUP=50 RUNS=2 OUT=/tmp/ab16 bash scripts/bench-ab.sh $M $M@$V "--particles 16777216 --grid 256" > $OUT/ab16-U2d.txt 2>&1
grep '^|' $OUT/ab-U2d.txt $OUT/ab16-U2d.txt
for t in gpu_kernels gpu_lifecycle; do
  MPM_PTX_DIR=$V timeout 100 $P/t/$t* > /tmp/$t.log 2>&1; echo "$t rc=$? $(grep 'test result' /tmp/$t.log)" | tee -a $OUT/tests.txt
done
