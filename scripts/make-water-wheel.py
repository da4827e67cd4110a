"""Writes scenes/water-wheel.obj, the `water-wheel` preset's wheel: a hub with eight flat paddles,
one closed surface extruded along z (the axle) and wound counter-clockwise seen from outside. Its
outline is star-shaped about the axle, so each face of the wheel is a fan about the axle's end.
The origin is the axle's centre; metres.

    python3 scripts/make-water-wheel.py > scenes/water-wheel.obj
"""
import math

PADDLES = 8
RADIUS = 0.08          # to the paddles' tips
HUB_RADIUS = 0.025
THICKNESS = 0.012      # of a paddle
WIDTH = 0.06           # along the axle
ARC_POINTS = 4         # on the hub between two paddles


def outline():
    """The wheel's outline in the x-y plane, counter-clockwise."""
    half = 0.5 * THICKNESS
    foot = math.sqrt(HUB_RADIUS ** 2 - half ** 2)  # where a paddle's side meets the hub
    gap = math.atan2(half, foot)                    # the hub's angle a paddle's side is off its centre line
    points = []
    for k in range(PADDLES):
        a = 2 * math.pi * k / PADDLES
        c, s = math.cos(a), math.sin(a)
        for x, y in [(foot, -half), (RADIUS, -half), (RADIUS, half), (foot, half)]:
            points.append((c * x - s * y, s * x + c * y))
        start, end = a + gap, a + 2 * math.pi / PADDLES - gap
        for j in range(1, ARC_POINTS + 1):
            t = start + (end - start) * j / (ARC_POINTS + 1)
            points.append((HUB_RADIUS * math.cos(t), HUB_RADIUS * math.sin(t)))
    return points


def main():
    ring = outline()
    n = len(ring)
    z = 0.5 * WIDTH
    print("# the water-wheel preset's wheel: scripts/make-water-wheel.py")
    for x, y in ring:
        print(f"v {x:.6f} {y:.6f} {-z:.6f}")
    for x, y in ring:
        print(f"v {x:.6f} {y:.6f} {z:.6f}")
    print(f"v 0 0 {-z:.6f}")
    print(f"v 0 0 {z:.6f}")
    back, front = 2 * n + 1, 2 * n + 2  # OBJ counts from 1
    for i in range(n):
        j = (i + 1) % n
        a, b = i + 1, j + 1            # back ring
        c, d = i + 1 + n, j + 1 + n    # front ring
        # The side: outward, as the outline runs counter-clockwise.
        print(f"f {a} {b} {d}")
        print(f"f {a} {d} {c}")
        # The front face (+z) counter-clockwise seen from +z, the back one the other way.
        print(f"f {front} {c} {d}")
        print(f"f {back} {b} {a}")


main()
