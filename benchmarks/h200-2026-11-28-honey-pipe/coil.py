import sys, os, glob, numpy as np
def read(path):
    data = open(path,'rb').read()
    end = data.index(b'end_header\n') + len(b'end_header\n')
    header = data[:end].decode()
    n = int([l for l in header.splitlines() if l.startswith('element vertex')][0].split()[2])
    dt = np.dtype([('x','<f4'),('y','<f4'),('z','<f4'),('vx','<f4'),('vy','<f4'),('vz','<f4'),('density','<f4'),('material','u1')])
    return np.frombuffer(data[end:end+n*dt.itemsize], dtype=dt)
d, dx, speed = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
cx = 30*dx
print('frame t n falling ybottom_cells r_cells theta_deg pile_top_cells rope_radius_mid_cells')
for f in sorted(glob.glob(d+'/frame_*.ply')):
    p = read(f); fr = int(f[-10:-4])
    if len(p) == 0: continue
    fall = p['vy'] < -0.5*speed
    q = p[fall]
    if len(q) < 20: print(fr, fr/60, len(p), len(q)); continue
    lo = np.quantile(q['y'], 0.05)
    b = q[q['y'] <= np.quantile(q['y'], 0.1)]
    ox, oz = b['x'].mean()-cx, b['z'].mean()-cx
    r = np.hypot(ox, oz)/dx; th = np.degrees(np.arctan2(oz, ox))
    slow = p[~fall]
    near = slow[np.hypot(slow['x']-cx, slow['z']-cx) < 8*dx]
    pile = near['y'].max()/dx if len(near) else 0
    mid = q[(q['y'] > lo + 0.4*(q['y'].max()-lo)) & (q['y'] < lo + 0.6*(q['y'].max()-lo))]
    rr = np.hypot(mid['x']-mid['x'].mean(), mid['z']-mid['z'].mean()).max()/dx if len(mid) else 0
    print(fr, '%.3f'%(fr/60), len(p), len(q), '%.1f'%(lo/dx), '%.2f'%r, '%.0f'%th, '%.1f'%pile, '%.2f'%rr)
