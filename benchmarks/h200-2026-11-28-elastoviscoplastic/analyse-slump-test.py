import sys, glob, re, math, numpy as np
sys.path.insert(0, sys.argv[1]); from ply import read
for log in sorted(glob.glob(sys.argv[2] + "/*.log")):
    name = log.split('/')[-1][:-4]; dx = float(name.split('-')[1]); K = name.split('-')[2]
    kes = [float(m) for m in re.findall(r"KE=([0-9.e+-]+) J", open(log).read())]
    peak = max(kes) if kes else float('nan')
    for path in sorted(glob.glob(f"{sys.argv[2]}/{name}/frame_*.ply")):
        frame = int(path.split('_')[-1][:-4])
        if frame == 0 or frame % 60: continue
        p = read(path)
        r = np.sqrt((p['x'] - dx)**2 + (p['z'] - dx)**2)
        V = 4 * len(r) * dx**3 / 8
        R = (225 * 1000 * 9.81 * V**2 / (128 * math.pi**2 * 50)) ** 0.2
        front = np.percentile(r, 99.9); front99 = np.percentile(r, 99)
        centre = p['y'][r < 2 * dx].max() + 0.25 * dx - dx
        ke = kes[frame - 1] if frame - 1 < len(kes) else float('nan')
        print(f"dx {dx} K {K} t {frame/60:.0f} s: V {V*1e3:.3f} L, R {front:.4f} m ({100*(front/R-1):+.1f} % of {R:.4f}; 99 %: {front99:.4f}), centre height {centre:.4f} (static {math.sqrt(2*50/9810*R):.4f}), KE/peak {ke/peak:.2e}")
