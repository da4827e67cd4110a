import sys, glob, numpy as np
sys.path.insert(0, sys.argv[1]); from ply import read
for path in sorted(glob.glob(sys.argv[2] + "/frame_*.ply")):
    p = read(path)
    x, y = p['x'], p['y']
    speed = np.sqrt(p['vx']**2 + p['vy']**2 + p['vz']**2)
    wall = x < 0.06
    print(path.split('/')[-1], "front (99.9%% x - 0.02) %.4f, height by the wall %.4f, |v| max %.2e mean %.2e, von_mises max %.0f, at yield (>= 0.99 sqrt3 600) %d of %d"
          % (np.percentile(x, 99.9) - 0.02, y[wall].max() + 0.005 - 0.02, speed.max(), speed.mean(), p['von_mises'].max(), (p['von_mises'] >= 0.99 * 3**0.5 * 600).sum(), len(x)))
