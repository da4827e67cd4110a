#!/usr/bin/env python3
"""Kernel time per device and kernel from an nsys sqlite export: total ms, launches, mean us."""
import sqlite3, sys
db = sqlite3.connect(sys.argv[1])
steps = float(sys.argv[2]) if len(sys.argv) > 2 else 1.0
q = """SELECT k.deviceId, s.value, COUNT(*), SUM(k.end - k.start) FROM CUPTI_ACTIVITY_KIND_KERNEL k
       JOIN StringIds s ON s.id = k.shortName GROUP BY k.deviceId, s.value ORDER BY k.deviceId, 4 DESC"""
print(f"{'dev':>3} {'kernel':<44} {'launches':>8} {'total ms':>10} {'ms/substep':>10}")
for dev, name, n, ns in db.execute(q):
    print(f"{dev:>3} {name[:44]:<44} {n:>8} {ns/1e6:>10.3f} {ns/1e6/steps:>10.4f}")
q = """SELECT k.deviceId, MIN(k.start), MAX(k.end) FROM CUPTI_ACTIVITY_KIND_KERNEL k GROUP BY k.deviceId"""
for dev, a, b in db.execute(q):
    print(f"device {dev}: kernels from {a/1e9:.3f} s to {b/1e9:.3f} s")
try:
    q = """SELECT copyKind, deviceId, COUNT(*), SUM(bytes), SUM(end-start) FROM CUPTI_ACTIVITY_KIND_MEMCPY GROUP BY copyKind, deviceId"""
    for kind, dev, n, b, ns in db.execute(q):
        print(f"memcpy kind {kind} device {dev}: {n} copies, {b/1e6:.1f} MB, {ns/1e6:.3f} ms")
except sqlite3.Error as e:
    print("no memcpy table:", e)
