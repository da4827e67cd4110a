#!/usr/bin/env bash
# Call 5: the largest run on two GPUs with ranks that hold their own particles and gather them only
# where something reads them: a billion-particle column (1e9 asked; 760^3 grid), and where that fails
# early, 6e8 (640^3). Peak GPU memory per device and host memory from samples. Writes largest.txt.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
free -g | head -2 >> $OUT/gpus.txt
largest() { # NAME LIMIT ARGS...
    local name=$1 limit=$2; shift 2
    nvidia-smi --query-gpu=index,memory.used --format=csv,noheader,nounits -lms 500 > /tmp/$name.mem 2>/dev/null &
    local sampler=$!
    ( while sleep 2; do free -m | awk '/Mem:/ {print $3}'; done ) > /tmp/$name.host &
    local host=$!
    local start=$SECONDS
    timeout $limit .gpu/bin/mpm bench "$@" --json $OUT/$name.json > $OUT/$name.log 2>&1
    local rc=$?
    kill $sampler $host 2>/dev/null; wait $sampler $host 2>/dev/null
    python3 - /tmp/$name.mem /tmp/$name.host $name $rc $((SECONDS - start)) <<'PY' >> $OUT/largest.txt
import sys
peak = {}
for line in open(sys.argv[1]):
    try:
        i, m = [int(v) for v in line.split(",")]
        peak[i] = max(peak.get(i, 0), m)
    except ValueError:
        pass
host = max([int(l) for l in open(sys.argv[2]) if l.strip().isdigit()] or [0])
print(f"{sys.argv[3]}: exit {sys.argv[4]} after {sys.argv[5]} s; peak GPU MiB {peak}; peak host MiB used {host}")
PY
    return $rc
}
largest billion 520 --particles 1000000000 --grid 760 --gpus 2 --steps 20 --warmup 5 \
  || { [ $SECONDS -lt 300 ] && largest six-hundred-million 280 --particles 600000000 --grid 640 --gpus 2 --steps 20 --warmup 5; }
cat $OUT/largest.txt; tail -25 $OUT/billion.log; tail -25 $OUT/six-hundred-million.log 2>/dev/null
