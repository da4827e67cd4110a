"""Writes scenes/glass.obj, the `tap` preset's glass: an open-topped, thick-walled cylinder with a
bottom, as one closed surface wound counter-clockwise seen from outside (outer wall, rim, inner wall,
inner bottom, outer bottom). Its base is at y = 0 and its axis the y axis; metres.

    python3 scripts/make-glass.py > scenes/glass.obj
"""
import math

SEGMENTS = 48
OUTER_RADIUS = 0.065
INNER_RADIUS = 0.045
HEIGHT = 0.120
BOTTOM = 0.020  # thickness of the base

vertices = []
triangles = []


def vertex(p):
    vertices.append(p)
    return len(vertices) - 1


def ring(radius, y):
    return [vertex((radius * math.cos(a), y, radius * math.sin(a)))
            for a in (2 * math.pi * k / SEGMENTS for k in range(SEGMENTS))]


def triangle(a, b, c, outward):
    """Adds a triangle, wound so that its normal points along `outward` (away from the solid)."""
    pa, pb, pc = vertices[a], vertices[b], vertices[c]
    u = [pb[i] - pa[i] for i in range(3)]
    v = [pc[i] - pa[i] for i in range(3)]
    normal = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
    if sum(normal[i] * outward[i] for i in range(3)) < 0:
        b, c = c, b
    triangles.append((a, b, c))


def band(lower, upper, outward):
    """Joins two rings with two triangles per segment."""
    for k in range(SEGMENTS):
        n = (k + 1) % SEGMENTS
        out = outward(k)
        triangle(lower[k], lower[n], upper[n], out)
        triangle(lower[k], upper[n], upper[k], out)


def fan(centre, rim, outward):
    for k in range(SEGMENTS):
        triangle(centre, rim[k], rim[(k + 1) % SEGMENTS], outward)


def radial(k, sign):
    a = 2 * math.pi * (k + 0.5) / SEGMENTS
    return (sign * math.cos(a), 0.0, sign * math.sin(a))


outer_base, outer_top = ring(OUTER_RADIUS, 0.0), ring(OUTER_RADIUS, HEIGHT)
inner_top, inner_base = ring(INNER_RADIUS, HEIGHT), ring(INNER_RADIUS, BOTTOM)
band(outer_base, outer_top, lambda k: radial(k, 1.0))        # outer wall
band(inner_top, outer_top, lambda k: (0.0, 1.0, 0.0))       # rim
band(inner_base, inner_top, lambda k: radial(k, -1.0))      # inner wall, facing the axis
fan(vertex((0.0, BOTTOM, 0.0)), inner_base, (0.0, 1.0, 0.0))   # inner bottom, facing up
fan(vertex((0.0, 0.0, 0.0)), outer_base, (0.0, -1.0, 0.0))     # outer bottom, facing down

print("# The tap preset's glass, written by scripts/make-glass.py: outer radius "
      f"{OUTER_RADIUS} m, inner {INNER_RADIUS} m, height {HEIGHT} m, base {BOTTOM} m thick;")
print(f"# {len(vertices)} vertices, {len(triangles)} triangles, base at y = 0, axis along y.")
for p in vertices:
    print("v {:.6f} {:.6f} {:.6f}".format(*p))
for t in triangles:
    print("f {} {} {}".format(*(i + 1 for i in t)))
