#!/usr/bin/env bash
# Call 7: the GPU test files on the final code (c351a26), gpu_bodies on the second GPU beside the
# others on the first; then the dam break in fixed point drawn headless on two GPUs (the render feed publishing the
# ranks' particles) against one GPU, frame 60 of each. Writes tests-*.txt, render.txt, two PNGs.
set -u
tar -xJf .gpu-pack/pack.tar.xz && for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
export NCCL_NVLS_ENABLE=0
nvidia-smi -L > $OUT/gpus.txt; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1 >> $OUT/gpus.txt
( CUDA_VISIBLE_DEVICES=1 timeout 270 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_bodies --out /tmp/tests-b --timeout 265 > $OUT/tests-bodies.txt 2>&1 ) &
bodies=$!
timeout 200 bash scripts/gpu-tests.sh --tests .gpu/tests --mpm .gpu/bin/mpm --only gpu_kernels,gpu_bench,gpu_nccl,gpu_nccl_pair,gpu_physics,gpu_materials,gpu_solids,gpu_pbmpm --out /tmp/tests-a --timeout 120 > $OUT/tests-others.txt 2>&1
tail -12 $OUT/tests-others.txt
if [ $SECONDS -lt 230 ]; then
  for case in one:"" gpus2:"--gpus 2"; do
    name=${case%%:*}; args=${case#*:}
    timeout 40 .gpu/bin/mpm render --backend cuda --scene dam-break --frames 60 --size 480x270 --scatter fixed-point --out /tmp/render-$name $args > /tmp/render-$name.log 2>&1
    echo "$name: exit $? $(tail -1 /tmp/render-$name.log)" >> $OUT/render.txt
    cp /tmp/render-$name/frame-00060.png $OUT/dam-break-$name-frame-60.png 2>/dev/null
  done
  python3 - <<'PY' >> $OUT/render.txt
import zlib, struct
def pixels(path):
    data = open(path, "rb").read()
    pos, idat = 8, b""
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        if kind == b"IDAT":
            idat += data[pos + 8:pos + 8 + n]
        pos += 12 + n
    return zlib.decompress(idat)
try:
    a, b = pixels("/tmp/render-one/frame-00060.png"), pixels("/tmp/render-gpus2/frame-00060.png")
    same = sum(x == y for x, y in zip(a, b)) / max(len(a), 1)
    print(f"frame 60, one GPU against two: {len(a)} and {len(b)} bytes of filtered rows, {same:.4f} of them equal")
except Exception as e:
    print("comparing the frames failed:", e)
PY
fi
cat $OUT/render.txt
wait $bodies
tail -4 $OUT/tests-bodies.txt
