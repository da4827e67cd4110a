#!/usr/bin/env python3
"""The dam break's surge front and water heights from `mpm run --export DIR` frames.

Usage: front.py DIR [DIR2]: one line per exported frame (60 Hz frames), with the front (the largest x
of the particles, less the 0.1 % farthest, so a lone droplet does not count), and the water height at
two gauges (the highest particle within half a cell of x = 0.5 m and x = 0.8 m, the middle 20 % of
the tank's depth). With DIR2, its figures beside DIR's and their difference.
"""
import glob, os, struct, sys

GAUGES = (0.5, 0.8)
HALF_CELL = 0.005


def read_ply(path):
    with open(path, "rb") as f:
        n = None
        while True:
            line = f.readline().decode().strip()
            if line.startswith("element vertex"):
                n = int(line.split()[-1])
            if line == "end_header":
                break
        data = f.read(28 * n)
    return [struct.unpack_from("<7f", data, 28 * i) for i in range(n)]


def measures(path):
    p = read_ply(path)
    xs = sorted(r[0] for r in p)
    front = xs[int(0.999 * (len(xs) - 1))]
    zs = [r[2] for r in p]
    z_lo, z_hi = min(zs), max(zs)
    mid = (z_lo + 0.4 * (z_hi - z_lo), z_lo + 0.6 * (z_hi - z_lo))
    heights = []
    for g in GAUGES:
        ys = [r[1] for r in p if abs(r[0] - g) < HALF_CELL and mid[0] <= r[2] <= mid[1]]
        heights.append(max(ys) if ys else 0.0)
    return front, heights


def frames(d):
    return sorted(glob.glob(os.path.join(d, "frame_*.ply")))


dirs = sys.argv[1:]
rows = [[measures(f) for f in frames(d)] for d in dirs]
print("| t (s) | " + " | ".join(f"front, {os.path.basename(d.rstrip('/'))} (m) | h({GAUGES[0]}) | h({GAUGES[1]})" for d in dirs)
      + (" | front difference | " if len(dirs) == 2 else " |"))
for k, f in enumerate(frames(dirs[0])):
    frame = int(os.path.basename(f)[6:12])
    cells = []
    for r in rows:
        front, (h1, h2) = r[k]
        cells.append(f"{front:.4f} | {h1:.4f} | {h2:.4f}")
    line = f"| {frame / 60:.3f} | " + " | ".join(cells)
    if len(dirs) == 2:
        line += f" | {rows[1][k][0] - rows[0][k][0]:+.4f} ({(rows[1][k][0] - rows[0][k][0]) / rows[0][k][0] * 100:+.1f} %)"
    print(line + " |")
