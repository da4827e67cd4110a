#!/usr/bin/env bash
# Call 6 (two GPUs): the ranks on two GPUs with two liquids; oil-on-water's layers at 4 s from a PLY.
set -u
rm -rf .gpu; mkdir -p .gpu && tar xJf .gpu-pack9/pack.tar.xz -C .gpu
export MPM_BIN=$PWD/.gpu/bin/mpm NCCL_NVLS_ENABLE=0
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/device.txt
timeout 400 bash .gpu/run bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --out /tmp/g --timeout 380 --only gpu_ranks_on_gpus 2>&1 | tail -4
grep -B2 -A3 "two_liquids" /tmp/g/gpu_ranks_on_gpus.log | head -20
bash .gpu/run .gpu/bin/mpm run --scene oil-on-water --frames 240 --backend cuda --export /tmp/e --every 60 > /tmp/e.txt 2>&1; tail -1 /tmp/e.txt; ls /tmp/e | head
python3 - <<'PY'
import glob, struct, re
for f in sorted(glob.glob('/tmp/e/*.ply')):
    data = open(f, 'rb').read()
    head, body = data.split(b'end_header\n', 1)
    head = head.decode()
    n = int(re.search(r'element vertex (\d+)', head).group(1))
    props = re.findall(r'property (\w+) (\w+)', head)
    fmt = {'float': 'f', 'uchar': 'B', 'uint8': 'B', 'int': 'i', 'uint': 'I', 'float32': 'f', 'ushort': 'H', 'uint16': 'H'}
    rec = '<' + ''.join(fmt[t] for t, _ in props)
    size = struct.calcsize(rec)
    names = [p for _, p in props]
    iy, im = names.index('y'), names.index('material')
    ys = {0: [], 1: []}
    for k in range(n):
        r = struct.unpack_from(rec, body, k * size)
        ys.setdefault(r[im], []).append(r[iy])
    def q(v, f):
        v = sorted(v); return v[int(f * (len(v) - 1))] if v else float('nan')
    w, o = ys[0], ys[1]
    surf = q(w + o, 0.99)
    print(f"{f.split('/')[-1]}: {len(w)} water, {len(o)} oil; surface (99th pct) {100*surf:.1f} cm; oil median {100*q(o,0.5):.1f} cm, 10th pct {100*q(o,0.1):.1f} cm; water median {100*q(w,0.5):.1f} cm; oil in the upper half of the liquid {100*sum(y > (surf + 0.01)/2 for y in o)/max(len(o),1):.0f} %")
PY
