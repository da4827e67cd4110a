set -u
cd "$(dirname "$0")"
for f in debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
M=$PWD/bin/mpm
mkdir -p $OUT/r /tmp/e
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/r/gpu.txt
for s in pipe150 pipe400 pipe1000 honey-real; do
  (timeout 420 $M run --scene $s.toml --frames 300 --backend cuda --export /tmp/e/$s --every 12 > $OUT/r/$s.log 2>&1) &
done
for s in bing3000 bing3000half bing60k bing60khalf; do
  (timeout 420 $M run --scene $s.toml --frames 150 --backend cuda --export /tmp/e/$s --every 30 > $OUT/r/$s.log 2>&1) &
done
wait
cd /tmp/e && tar cf - pipe150 pipe400 | xz -3 -T8 > $OUT/honey-a.tar.xz; tar cf - pipe1000 honey-real | xz -3 -T8 > $OUT/honey-b.tar.xz; tar cf - bing* | xz -3 -T8 > $OUT/bing.tar.xz
cd $OUT && tar cf logs.tar r
ls -la $OUT
