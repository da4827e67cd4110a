# Reads mpm's binary PLY (x y z vx vy vz density as f32, material u8, then J von_mises f32 where solids).
import numpy as np, sys
def read(path):
    with open(path, 'rb') as f:
        props = []; n = 0
        while True:
            line = f.readline().decode().strip()
            if line.startswith('element vertex'): n = int(line.split()[2])
            if line.startswith('property'): props.append((line.split()[1], line.split()[2]))
            if line == 'end_header': break
        dt = np.dtype([(name, '<f4' if t == 'float' else 'u1') for t, name in props])
        return np.frombuffer(f.read(n * dt.itemsize), dtype=dt, count=n)
