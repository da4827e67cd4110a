# The figures of docs/physics.md's "What the yield stress does not do yet" from the runs' last PLY
# frames (mpm run --scene bingNAME.toml --frames 150 --backend cuda --export DIR --every 30):
# the static profile's runout and heights as tests/materials.rs measures them, and where the
# kinetic energy left is. Usage: python3 analyse.py DIR... (each DIR holding frame_000150.ply).
import sys, numpy as np
def read(path):
    data = open(path, 'rb').read()
    end = data.index(b'end_header\n') + len(b'end_header\n')
    n = int([l for l in data[:end].decode().splitlines() if l.startswith('element vertex')][0].split()[2])
    dt = np.dtype([('x','<f4'),('y','<f4'),('z','<f4'),('vx','<f4'),('vy','<f4'),('vz','<f4'),('density','<f4'),('material','u1')])
    return np.frombuffer(data[end:end + n * dt.itemsize], dtype=dt)
dx, rho, tau, g = 0.05, 1000.0, 800.0, 9.81
wall = floor = dx
for d in sys.argv[1:]:
    p = read(f'{d}/frame_000150.ply')
    area = len(p) * dx**3 / 8 / 0.25
    scale = 2 * tau / (rho * g)
    runout = (1.5 * area / np.sqrt(scale)) ** (2 / 3)
    front = np.quantile(p['x'] - wall, 0.999)
    line = [f'{d}: runout {front:.3f} m against {runout:.3f} ({100 * (front / runout - 1):+.1f} %)']
    for f in [0.25, 0.5]:
        x0 = wall + np.floor(f * runout / dx) * dx
        h = p['y'][(p['x'] >= x0) & (p['x'] < x0 + dx)].max() + 0.25 * dx - floor
        line.append(f'h at {f} of it {100 * (h / np.sqrt(scale * (runout - (x0 + 0.5 * dx - wall))) - 1):+.1f} %')
    speed = np.hypot(p['vx'], p['vy'])
    line.append(f'speed within 10 cm of the wall {speed[p["x"] < 0.15].max():.4f} m/s, at most {speed.max():.4f} m/s')
    line.append(f'rms vx {np.sqrt((p["vx"]**2).mean()):.4f}, vy {np.sqrt((p["vy"]**2).mean()):.4f} m/s')
    print('; '.join(line))
