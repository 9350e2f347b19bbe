#!/usr/bin/env python3
"""Write partition.obj, the serpentine partition of tabletop_separated.xml
(docs/descriptor.md §7, paper §5 Finding 1; design record in
docs/scenes.md "tabletop pair: design record").

The six balls of include/tabletop_common.xml stand in three rows across the
table, the two families interleaved: the middle column alternates delta-S,
glossy, delta-S from front to back, and the glossy middle ball lies inside
the triangle of the three delta-S balls. The partition is one opaque wall
that weaves through that column like a belt round pulleys: it wraps the
right side of the front and back delta-S balls and the left side of the
middle glossy ball (arcs at a fixed clearance round each of them, joined
by their crossing common tangents), with straight tails along y in front
of the front row and behind the back row. Every delta-S ball lies wholly
to its left (-x side) at every y it spans and every glossy ball wholly to
its right, and the wall is taller than every ball, so every straight
segment from a delta-S ball to a glossy ball crosses it: the partition
blocks every delta-S <-> glossy sight line (mutual visibility 0).

The ball table below must match include/tabletop_common.xml; the script
checks the clearances and sides and refuses to write a partition that
touches a ball or leaves one on the wrong side.
Units: metres, z up, table top at z = 0.

Usage: python3 scenes/tabletop/generate.py   (rewrites partition.obj beside it)
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))

# id: (x, y, radius, family); every ball rests on the table (centre z = radius).
BALLS = {
    "glass_sphere": (0.04, -0.35, 0.09, "delta"),
    "aluminium_sphere": (0.27, -0.35, 0.09, "glossy"),
    "chrome_sphere": (-0.29, 0.00, 0.10, "delta"),
    "gold_sphere": (-0.04, 0.00, 0.10, "glossy"),
    "mirror_sphere": (0.04, 0.35, 0.10, "delta"),
    "frosted_sphere": (0.27, 0.35, 0.08, "glossy"),
}
# The pulleys, front to back: (ball, +1 = the wall passes on the ball's
# right, i.e. the ball is on the left of the direction of travel; -1 left).
PULLEYS = [("glass_sphere", +1), ("gold_sphere", -1), ("mirror_sphere", +1)]

THICKNESS = 0.02  # wall thickness (m)
CLEARANCE = 0.015  # pulley surface to wall surface (m)
HEIGHT = 0.21  # wall top; the tallest ball reaches 0.20
BOTTOM = -0.005  # just below the table top, so no light leaks under it
TAIL = 0.14  # straight tails beyond the first and last tangent point (m)
ARC_STEP = math.radians(3.0)  # centreline sampling on the arcs


def pulley(name):
    x, y, r, _ = BALLS[name]
    return (x, y), r + CLEARANCE + 0.5 * THICKNESS


def crossing_tangent(a, ra, sa, b, rb, sb):
    """Common tangent from circle a (side sa) to circle b (side sb): the
    unit direction d and the tangent points. Side +1: the centre is on the
    left of d (centre = point + r * left(d))."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    length = math.hypot(dx, dy)
    # left(d) = n; point_a = a - sa ra n, point_b = b - sb rb n, and
    # n . (point_b - point_a) = 0  =>  n . (b - a) = sb rb - sa ra.
    k = (sb * rb - sa * ra) / length
    if abs(k) >= 1.0:
        raise SystemExit("pulleys %s and %s are too close for a tangent" % (a, b))
    base = math.atan2(dy, dx)
    for sign in (+1, -1):
        alpha = base + sign * math.acos(k)  # angle of n
        n = (math.cos(alpha), math.sin(alpha))
        d = (n[1], -n[0])  # n = left(d)  <=>  d = right(n)
        if d[0] * dx + d[1] * dy > 0.0:
            pa = (a[0] - sa * ra * n[0], a[1] - sa * ra * n[1])
            pb = (b[0] - sb * rb * n[0], b[1] - sb * rb * n[1])
            return d, pa, pb
    raise SystemExit("no forward tangent")


def arc(c, r, side, p0, p1):
    """Points on circle (c, r) from p0 to p1 (both on it), counter-clockwise
    when side = +1 (centre on the left of travel), clockwise otherwise."""
    t0 = math.atan2(p0[1] - c[1], p0[0] - c[0])
    t1 = math.atan2(p1[1] - c[1], p1[0] - c[0])
    sweep = t1 - t0
    if side > 0:
        while sweep < 0.0:
            sweep += 2.0 * math.pi
    else:
        while sweep > 0.0:
            sweep -= 2.0 * math.pi
    n = max(1, int(math.ceil(abs(sweep) / ARC_STEP)))
    return [(c[0] + r * math.cos(t0 + sweep * i / n), c[1] + r * math.sin(t0 + sweep * i / n)) for i in range(n + 1)]


def centreline():
    """The wall's centreline, front (-y) to back (+y), as a polyline."""
    circles = [pulley(name) + (side,) for name, side in PULLEYS]
    # Straight tails along +y, tangent to the first and last pulley at their
    # +x (side +1) or -x (side -1) point.
    (c0, r0, s0), (cn, rn, sn) = circles[0], circles[-1]
    start_touch = (c0[0] + s0 * r0, c0[1])
    end_touch = (cn[0] + sn * rn, cn[1])
    pts = [(start_touch[0], start_touch[1] - TAIL)]
    enter = start_touch
    for i in range(len(circles) - 1):
        (ca, ra, sa), (cb, rb, sb) = circles[i], circles[i + 1]
        _, pa, pb = crossing_tangent(ca, ra, sa, cb, rb, sb)
        pts += arc(ca, ra, sa, enter, pa)
        enter = pb
    pts += arc(cn, rn, sn, enter, end_touch)
    pts.append((end_touch[0], end_touch[1] + TAIL))
    # Drop repeated points (a zero-length arc at a tangent point).
    out = [pts[0]]
    for p in pts[1:]:
        if math.hypot(p[0] - out[-1][0], p[1] - out[-1][1]) > 1e-9:
            out.append(p)
    return out


def point_segment(p, a, b):
    ax, ay = b[0] - a[0], b[1] - a[1]
    t = ((p[0] - a[0]) * ax + (p[1] - a[1]) * ay) / (ax * ax + ay * ay)
    t = min(1.0, max(0.0, t))
    return math.hypot(p[0] - a[0] - t * ax, p[1] - a[1] - t * ay)


def check(line):
    """Every ball clears the wall and lies on its family's side of it at
    every y it spans (the centreline is monotone in y)."""
    for i in range(len(line) - 1):
        if not line[i + 1][1] > line[i][1]:
            raise SystemExit("the centreline is not monotone in y at %s" % (line[i],))
    worst = float("inf")
    for name, (x, y, r, family) in BALLS.items():
        gap = min(point_segment((x, y), line[i], line[i + 1]) for i in range(len(line) - 1)) - r - 0.5 * THICKNESS
        if gap <= 0.0:
            raise SystemExit("%s touches the partition (gap %.4f m)" % (name, gap))
        if not (line[0][1] < y - r and line[-1][1] > y + r):
            raise SystemExit("%s reaches past the end of the partition" % name)
        # the wall's x at the ball's y
        for i in range(len(line) - 1):
            (x0, y0), (x1, y1) = line[i], line[i + 1]
            if y0 <= y <= y1:
                xw = x0 + (x1 - x0) * (y - y0) / (y1 - y0)
                break
        left = x < xw
        if left != (family == "delta"):
            raise SystemExit("%s is on the wrong side of the partition" % name)
        print("  %-17s %-6s %s of the wall, clearance %.4f m" % (name, family, "left " if left else "right", gap))
        worst = min(worst, gap)
    print("  smallest ball-wall clearance %.4f m" % worst)
    if HEIGHT <= max(2.0 * r for _, _, r, _ in BALLS.values()):
        raise SystemExit("the partition is not taller than every ball")


def extrude(line):
    """A closed prism: the centreline offset by +-THICKNESS/2, from BOTTOM to
    HEIGHT. Outward-facing counter-clockwise triangles."""
    n = len(line)
    left, right = [], []
    for i, p in enumerate(line):
        a = line[max(0, i - 1)]
        b = line[min(n - 1, i + 1)]
        tx, ty = b[0] - a[0], b[1] - a[1]
        tl = math.hypot(tx, ty)
        nx, ny = -ty / tl, tx / tl  # left normal
        h = 0.5 * THICKNESS
        left.append((p[0] + h * nx, p[1] + h * ny))
        right.append((p[0] - h * nx, p[1] - h * ny))
    verts = []
    # 4 vertices per station: left bottom, left top, right bottom, right top
    for l, r in zip(left, right):
        verts += [(l[0], l[1], BOTTOM), (l[0], l[1], HEIGHT), (r[0], r[1], BOTTOM), (r[0], r[1], HEIGHT)]
    faces = []

    def quad(a, b, c, d):  # a b c d counter-clockwise seen from outside
        faces.append((a, b, c))
        faces.append((a, c, d))

    for i in range(n - 1):
        lb, lt, rb, rt = 4 * i, 4 * i + 1, 4 * i + 2, 4 * i + 3
        lb2, lt2, rb2, rt2 = lb + 4, lt + 4, rb + 4, rt + 4
        quad(lb, lt, lt2, lb2)  # left side, facing the left normal
        quad(rb, rb2, rt2, rt)  # right side
        quad(lt, rt, rt2, lt2)  # top
        quad(lb, lb2, rb2, rb)  # bottom
    last = 4 * (n - 1)
    quad(0, 2, 3, 1)  # front cap (facing -travel)
    quad(last, last + 1, last + 3, last + 2)  # back cap
    return verts, faces


def main():
    line = centreline()
    print("partition centreline: %d points, y from %.3f to %.3f" % (len(line), line[0][1], line[-1][1]))
    check(line)
    verts, faces = extrude(line)
    # Sanity: the winding faces outwards (positive signed volume).
    vol = 0.0
    for a, b, c in faces:
        pa, pb, pc = verts[a], verts[b], verts[c]
        vol += (pa[0] * (pb[1] * pc[2] - pb[2] * pc[1]) - pa[1] * (pb[0] * pc[2] - pb[2] * pc[0])
                + pa[2] * (pb[0] * pc[1] - pb[1] * pc[0])) / 6.0
    if vol <= 0.0:
        raise SystemExit("inward-facing winding (volume %g)" % vol)
    lines = [
        "# Serpentine partition of tabletop_separated.xml, generated by generate.py",
        "# (do not edit: change generate.py and rerun it). %d vertices, %d triangles," % (len(verts), len(faces)),
        "# %.3f m thick, z from %.3f to %.3f, volume %.6f m^3. Units: metres, z up." % (THICKNESS, BOTTOM, HEIGHT, vol),
    ]
    lines += ["v %.6f %.6f %.6f" % v for v in verts]
    lines += ["f %d %d %d" % (a + 1, b + 1, c + 1) for a, b, c in faces]
    with open(os.path.join(HERE, "partition.obj"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("wrote partition.obj: %d vertices, %d triangles, volume %.6f m^3" % (len(verts), len(faces), vol))


if __name__ == "__main__":
    main()
