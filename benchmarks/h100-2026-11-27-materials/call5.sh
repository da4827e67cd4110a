#!/usr/bin/env bash
# Call 5 (2026-11-27, materials): the mud preset on a no-slip floor (scene file, same build as call 3).
set -u
R=$OUT/r; mkdir -p $R .gpu/bin; rm -rf /tmp/mud5 /tmp/mud5p
xz -dc .gpu-pack5/mpm.xz > .gpu/bin/mpm && chmod +x .gpu/bin/mpm
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $R/device.txt
.gpu/bin/mpm run --scene scenes/mud-dam-break.toml --frames 240 --export /tmp/mudply --every 240 > $R/run-mud.txt 2>&1; echo "run exit $?"; grep "^frame" $R/run-mud.txt | awk 'NR%30==0' | cut -c1-190; tail -1 $R/run-mud.txt
python3 - <<'PY' > $R/profile.txt
import struct,glob
f=sorted(glob.glob('/tmp/mudply/*.ply'))[-1]; d=open(f,'rb').read(); e=d.index(b'end_header\n')+11
h=d[:e].decode().split('\n'); n=int([l for l in h if l.startswith('element vertex')][0].split()[2])
props=[l.split() for l in h if l.startswith('property')]; stride=sum(1 if p[1]=='uchar' else 4 for p in props)
xs=[];ys=[]
for i in range(n):
    x,y,z=struct.unpack_from('<3f',d,e+i*stride); xs.append(x); ys.append(y)
import math
print(f, n)
for b in range(0,80,4):
    lo,hi=b*0.02,(b+4)*0.02; col=[y for x,y in zip(xs,ys) if lo<=x<hi]
    print(f"x {lo:.2f}-{hi:.2f}: n {len(col)} top {max(col) if col else 0:.3f}")
PY
cat $R/profile.txt
bash .gpu/run .gpu/bin/mpm render --scene scenes/mud-dam-break.toml --frames 240 --size 960x540 --colour material --out /tmp/mud5 > $R/render.txt 2>&1; echo "render exit $?"
for k in 20 60 240; do cp /tmp/mud5/frame-$(printf %05d $k).png $R/; done
tar czf $OUT/mud.tgz -C $OUT r && rm -rf $R
