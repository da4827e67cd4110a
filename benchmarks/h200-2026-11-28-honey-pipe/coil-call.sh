set -u
cd "$(dirname "$0")"
for f in debs/*.deb; do dpkg -x "$f" / 2>/dev/null; done; ldconfig
M=$PWD/bin/mpm
mkdir -p $OUT/r /tmp/e /tmp/png
nvidia-smi --query-gpu=name,driver_version --format=csv > $OUT/r/gpu.txt
run() { s=$1; frames=$2; timeout 470 $M run --scene $s.toml --frames $frames --backend cuda --export /tmp/e/$s --every 3 > $OUT/r/$s.log 2>&1; }
rend() { s=$1; frames=$2; timeout 470 $M render --scene $s.toml --frames $frames --out /tmp/png/$s --size 480x360 --colour speed > $OUT/r/$s-render.log 2>&1; }
run s100 300 & run s300 300 & run r10a 240 & run r10b 240 &
rend s100 300 & rend s300 300 & rend r10a 240 & rend r10b 240 &
wait
python3 coil.py /tmp/e/s100 0.005 0.05 > $OUT/r/s100.coil; python3 coil.py /tmp/e/s300 0.005 0.05 > $OUT/r/s300.coil
python3 coil.py /tmp/e/r10a 0.0005 0.02 > $OUT/r/r10a.coil; python3 coil.py /tmp/e/r10b 0.0005 0.05 > $OUT/r/r10b.coil
mkdir -p /tmp/keep; for s in s100 s300 r10a r10b; do for f in /tmp/png/$s/*.png; do n=$(basename $f .png); n=${n##*_}; n=$((10#$n)); [ $((n % 20)) -eq 0 ] && cp $f /tmp/keep/$s-$n.png; done; done
ls /tmp/png/s100 | head -3
cd /tmp/keep && tar cf $OUT/png.tar . ; cd /tmp/e && for s in s100 s300 r10a r10b; do ls $s/*.ply | awk 'NR%10==1' ; done > /tmp/sel; tar cf - -T /tmp/sel | xz -3 -T8 > $OUT/ply.tar.xz
cd $OUT && tar cf logs.tar r; ls -la $OUT
