import sys, os, struct
# Largest position difference between two runs' PLY files, frame by frame (records in file order).
def positions(path):
    data = open(path, 'rb').read()
    head = data[:data.index(b'end_header\n')].decode()
    props = [l.split()[-1] for l in head.splitlines() if l.startswith('property')]
    body = data[data.index(b'end_header\n') + 11:]
    n = len(props)
    vals = struct.unpack(f'<{len(body) // 4}f', body[: len(body) // 4 * 4])
    return [vals[i:i + 3] for i in range(0, len(vals), n)]
a, b = sys.argv[1], sys.argv[2]
files = sorted(f for f in os.listdir(a) if f.endswith('.ply'))
for f in files:
    pa, pb = positions(f"{a}/{f}"), positions(f"{b}/{f}")
    worst = max((max(abs(x - y) for x, y in zip(u, v)) for u, v in zip(pa, pb)), default=0.0)
    differing = sum(u != v for u, v in zip(pa, pb))
    if f == files[1] or f == files[10] or f == files[-1]:
        print(f"{f}: {differing} of {len(pa)} positions differ, largest by {worst:.3g} m")
