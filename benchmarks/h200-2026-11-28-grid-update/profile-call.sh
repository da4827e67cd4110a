set -u
P=/tmp/p11; mkdir -p $P; tar xJf $PWD/.gpu-pack11/pack.tar.xz -C $P
for f in $P/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
M=$P/mpm
mkdir -p $OUT
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/gpu.txt
$M bench --scene dam-break --steps 1000 --warmup 100 > $OUT/bench-dam.txt 2>&1
$M bench --particles 16777216 --grid 256 --steps 200 --warmup 50 > $OUT/bench-16m.txt 2>&1
S="--section SpeedOfLight --section Occupancy --section LaunchStats --section WarpStateStats --section MemoryWorkloadAnalysis --section SchedulerStats"
ncu --clock-control none -k regex:grid_update_blocks --launch-skip 200 --launch-count 3 $S -f -o /tmp/pdam $M bench --scene dam-break --steps 300 --warmup 10 > $OUT/ncu-dam.log 2>&1
ncu --import /tmp/pdam.ncu-rep --page details > $OUT/ncu-dam.txt 2>&1
ncu --clock-control none -k regex:grid_update_blocks --launch-skip 40 --launch-count 2 $S -f -o /tmp/p16 $M bench --particles 16777216 --grid 256 --steps 60 --warmup 10 > $OUT/ncu-16m.log 2>&1
ncu --import /tmp/p16.ncu-rep --page details > $OUT/ncu-16m.txt 2>&1
ls -la $OUT
