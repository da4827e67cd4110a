#!/usr/bin/env python3
"""Surge front and gauge heights of `mpm run --export` frames (the measures of tests/gpu_physics.rs),
and the largest differences between runs. Usage: gauges.py NAME=DIR ... ; pairs compared: each with the first."""
import glob, sys
import numpy as np
GAUGES = (0.15, 0.65); HALF = 0.025; DX = 0.01; WIDTH = (50 - 3) * DX; M_OVER_RHO = 1.25e-4 / 1000.0
def read(path):
    with open(path, "rb") as f:
        n = None
        while True:
            line = f.readline().decode().strip()
            if line.startswith("element vertex"): n = int(line.split()[-1])
            if line == "end_header": break
        return np.frombuffer(f.read(28 * n), dtype="<f4").reshape(n, 7)
def measures(d):
    out = []
    for path in sorted(glob.glob(d + "/frame_*.ply"))[1:]:
        p = read(path)
        front = p[p[:, 1] < 0.05, 0].max()
        h = [np.count_nonzero(np.abs(p[:, 0] - g) < HALF) * M_OVER_RHO / (2 * HALF * WIDTH) for g in GAUGES]
        out.append((front, h[0], h[1]))
    return np.array(out)
runs = [(a.split("=")[0], measures(a.split("=")[1])) for a in sys.argv[1:]]
base_name, base = runs[0]
for name, m in runs:
    print(name, " ".join(f"{r[0]:.3f}/{r[1]:.4f}/{r[2]:.4f}" for r in m[::3]))
for name, m in runs[1:]:
    k = min(len(m), len(base))
    pre = base[:k, 0] < 0.95
    df = np.max(np.abs(m[:k, 0] - base[:k, 0])[pre] / base[:k, 0][pre])
    dh = np.max(np.abs(m[:k, 1:] - base[:k, 1:]) / 0.40, axis=0)
    worst_t = (np.argmax(np.abs(m[:k, 1] - base[:k, 1])) + 1) * 3 / 60
    print(f"{name} vs {base_name}: front {100*df:.2f} %, gauge 0.15 {100*dh[0]:.2f} % (worst at {worst_t:.2f} s), gauge 0.65 {100*dh[1]:.2f} % of the column")
