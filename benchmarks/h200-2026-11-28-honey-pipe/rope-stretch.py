import sys, numpy as np
def read(path):
    data = open(path,'rb').read()
    end = data.index(b'end_header\n') + len(b'end_header\n')
    n = int([l for l in data[:end].decode().splitlines() if l.startswith('element vertex')][0].split()[2])
    dt = np.dtype([('x','<f4'),('y','<f4'),('z','<f4'),('vx','<f4'),('vy','<f4'),('vz','<f4'),('density','<f4'),('material','u1')])
    return np.frombuffer(data[end:end+n*dt.itemsize], dtype=dt)
f, dx, yexit = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
mu, rho, g = 150.0, 1400.0, 9.8; nu = mu/rho
p = read(f); y = p['y']; u = -p['vy']
slab = dx  # two particle layers a slab
print('rope from %.4f down to %.4f (L = %.4f m)' % (yexit, y.min(), yexit - y.min()))
tops = np.arange(yexit, y.min(), -slab)
rows = [(t - slab/2, ((y <= t) & (y > t - slab)).sum(), u[(y <= t) & (y > t - slab)].mean(), (y <= t - slab/2).sum()) for t in tops if ((y <= t) & (y > t - slab)).sum()]
for i in range(1, len(rows) - 1):
    z, n, uu, below = rows[i]
    dudz = (rows[i+1][2] - rows[i-1][2]) / (rows[i-1][0] - rows[i+1][0])
    ratio = g * below * slab / (nu * n * dudz) if dudz > 0 else float('nan')
    print('y=%.4f n=%5d u=%.4f du/dz=%.3f below=%6d  weight/(mu A du/dz)=%.2f' % (z, n, uu, dudz, below, ratio))
