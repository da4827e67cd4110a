import sys, os
def records(path):
    data = open(path, 'rb').read()
    body = data[data.index(b'end_header\n') + 11:]
    return sorted(body[i:i + 28] for i in range(0, len(body), 28))
a, b = sys.argv[1], sys.argv[2]
files = sorted(f for f in os.listdir(a) if f.endswith('.ply'))
same = sum(records(f"{a}/{f}") == records(f"{b}/{f}") for f in files)
print(f"{same} of {len(files)} PLY files hold the same records as sets")
