#!/usr/bin/env bash
# Session 29 call 1: the substep's volume bound (MIN_SUBSTEP_VOLUME_RATIO) and the position-based
# substep as a CUDA graph, against main before them (.gpu/bin/mpm-old) on one GPU: the GPU tests of
# pbmpm and of the graphs, byte identity (graphs on against off; old against new where the bound
# cannot act), which settings hold the dam break now (1M, 3M, 10M), and the frame cost before/after.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
export NCCL_NVLS_ENABLE=0
L=/tmp/logs; rm -rf $L /tmp/ply-*; mkdir -p $L
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $L/gpu.txt
NEW=.gpu/bin/mpm OLD=.gpu/bin/mpm-old
printf '#!/usr/bin/env bash\nMPM_CUDA_GRAPHS=0 exec %s "$@"\n' "$PWD/$NEW" > /tmp/mpm-nographs; chmod +x /tmp/mpm-nographs
for t in gpu_pbmpm gpu_kernels; do
  timeout 400 .gpu/tests/$t > $L/test-$t.log 2>&1; echo "== test $t rc $?"; grep -E "^test result|passed|failed|RESULT pbmpm GPU graphs" $L/test-$t.log | tail -4
done
echo "== ply: graphs on against off (new build)"
timeout 120 bash scripts/ply-identity.sh $NEW /tmp/mpm-nographs /tmp/ply-graphs --scenes "pbmpm-dam-break:60 pbmpm-jelly-drop:60 pbmpm-1m:20" --every 10 > $L/ply-graphs.txt 2>&1; echo "rc $?"; grep -v "^  " $L/ply-graphs.txt | tail -4
echo "== ply: old against new"
timeout 120 bash scripts/ply-identity.sh $OLD $NEW /tmp/ply-old-new --scenes "pbmpm-jelly-drop:60 pbmpm-dam-break:120 pbmpm-1m:60" --every 10 > $L/ply-old-new.txt 2>&1; echo "rc $?"; grep -v "^  " $L/ply-old-new.txt | tail -5
S=benchmarks/h200-2026-11-30-pbmpm-window/scenes
sweep() { # scene frames
  b=$(basename $1 .toml)
  timeout 150 $NEW run --backend cuda --scene $1 --frames $2 > $L/run-$b.log 2>&1; rc=$?
  echo "== $b rc $rc $(grep -c '^frame' $L/run-$b.log) frames; $(grep '^time:' $L/run-$b.log)"
  grep "^frame" $L/run-$b.log | sed -E 's/.*rho\/rho0=\[[0-9.]+ ([0-9.]+) ([0-9.]+)\].*/\2 \1/' | sort -g | tail -1 | sed 's/^/   densest, its mean: /'
  grep "^frame" $L/run-$b.log | sed -E 's/.*rho\/rho0=\[[0-9.]+ ([0-9.]+) ([0-9.]+)\].*/\1/' | sort -g | tail -1 | sed 's/^/   largest mean: /'
  grep -iE "error|overflow" $L/run-$b.log | head -2
}
for s in 4-i1 4-i2 4-i4 6-i2 8-i1 8-i2; do sweep $S/pb-1m-s$s.toml 300; done
for s in 6-i2 8-i2 12-i2; do sweep $S/pb-3m-s$s.toml 150; done
for s in 8-i2 12-i2; do sweep $S/pb-10m-s$s.toml 150; done
echo "== bench before/after"
OUT=$L/bench STEPS=1000 WARMUP=100 RUNS=2 timeout 200 bash scripts/bench-ab.sh $OLD $NEW "--scene pbmpm-1m" "--scene pbmpm-dam-break" "--scene dam-break" > $L/bench.txt 2>&1; echo "rc $?"; tail -12 $L/bench.txt
for f in /tmp/ply-*/summary.txt; do cp $f $L/$(basename $(dirname $f))-summary.txt; done
tar -czf $OUT/logs.tgz -C /tmp logs
