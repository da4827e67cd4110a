import sys, glob, re, numpy as np
sys.path.insert(0, sys.argv[1]); from ply import read
for log in sorted(glob.glob(sys.argv[2] + "/*.log")):
    name = log.split("/")[-1][:-4]; dx = float(name.split("-")[1]); K = name.split("-")[2]; tau = float(name.split("-")[3])
    kes = [float(m) for m in re.findall(r"KE=([0-9.e+-]+) J", open(log).read())]
    peak = max(kes) if kes else float('nan')
    for path in sorted(glob.glob(f"{sys.argv[2]}/{name}/frame_*.ply")):
        frame = int(path.split('_')[-1][:-4])
        if frame == 0 or frame % 120: continue
        p = read(path); x, y = p['x'], p['y']
        a = len(x) * dx**3 / 8 / 0.25; scale = 2 * tau / (1000 * 9.81)
        runout = (1.5 * a / scale**0.5) ** (2 / 3)
        front = np.percentile(x, 99.9, method='nearest') - dx
        hs = []
        for f in [0.25, 0.5, 0.75]:
            x0 = dx + np.floor(f * runout / dx) * dx; xm = x0 + 0.5 * dx - dx
            col = y[(x >= x0) & (x < x0 + dx)]
            h = col.max() + 0.25 * dx - dx if len(col) else 0
            hs.append(100 * (h / (scale * (runout - xm))**0.5 - 1))
        ke = kes[frame - 1] if frame - 1 < len(kes) else float('nan')
        print(f"dx {dx} tau {tau:.0f} K {K} t {frame/60:.1f} s: front {front:.4f} ({100*(front/runout-1):+.1f} %), h {hs[0]:+.1f} {hs[1]:+.1f} {hs[2]:+.1f} %, KE/peak {ke/peak:.2e}")
