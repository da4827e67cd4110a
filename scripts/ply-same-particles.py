#!/usr/bin/env python3
"""Whether two folders of particle PLY files (mpm run --export) hold the same particles, property by
property, where their layouts differ: a build that adds a property (the material row) must leave
every property the older build wrote unchanged, bit for bit.

    scripts/ply-same-particles.py DIR_A DIR_B

Compares every frame_*.ply the two folders share, on the properties both files have (by name), as
raw bytes; prints one line a file and exits 0 when all are the same, 1 when any differs or a file
is missing on one side, 2 on a bad argument. Only binary little-endian PLY (what mpm writes)."""
import os
import struct
import sys

SIZES = {"char": 1, "uchar": 1, "short": 2, "ushort": 2, "int": 4, "uint": 4, "float": 4, "double": 8}


def read(path):
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    if "format binary_little_endian 1.0" not in header:
        sys.exit(f"{path}: not a binary little-endian PLY")
    count, props = 0, []
    for line in header:
        words = line.split()
        if words[:2] == ["element", "vertex"]:
            count = int(words[2])
        elif words[:1] == ["property"]:
            props.append((words[2], SIZES[words[1]]))
    stride = sum(size for _, size in props)
    columns, offset = {}, 0
    for name, size in props:
        columns[name] = (offset, size)
        offset += size
    return data[end:], count, stride, columns


def main():
    if len(sys.argv) != 3 or not all(os.path.isdir(d) for d in sys.argv[1:]):
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 2
    a_dir, b_dir = sys.argv[1:]
    names = sorted(set(os.listdir(a_dir)) | set(os.listdir(b_dir)))
    names = [n for n in names if n.startswith("frame_") and n.endswith(".ply")]
    bad = 0
    for name in names:
        if not (os.path.exists(os.path.join(a_dir, name)) and os.path.exists(os.path.join(b_dir, name))):
            print(f"{name}: on one side only")
            bad += 1
            continue
        a, na, sa, ca = read(os.path.join(a_dir, name))
        b, nb, sb, cb = read(os.path.join(b_dir, name))
        shared = [p for p in ca if p in cb]
        if na != nb:
            print(f"{name}: {na} against {nb} particles")
            bad += 1
            continue
        differ = []
        for prop in shared:
            (oa, size), (ob, _) = ca[prop], cb[prop]
            if any(a[i * sa + oa : i * sa + oa + size] != b[i * sb + ob : i * sb + ob + size] for i in range(na)):
                differ.append(prop)
        if differ:
            print(f"{name}: {', '.join(differ)} differ")
            bad += 1
        else:
            print(f"{name}: same ({na} particles; {', '.join(shared)})")
    print(f"{len(names) - bad} of {len(names)} files hold the same particles")
    return 1 if bad or not names else 0


if __name__ == "__main__":
    sys.exit(main())
