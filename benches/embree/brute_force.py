#!/usr/bin/env python3
"""Decides rays on which two tracers disagree, by brute force in exact arithmetic.

Usage: brute_force.py FILE.bin RAY [RAY ...]

FILE.bin is a dump of the accel bench (`ACCEL_DUMP`, format in its `dump`); RAY an
index of its incoherent rays (embree_rays lists those on which Embree and Coatlab
disagree). Every triangle of the mesh is tested against the ray in double precision
(Möller–Trumbore) to find candidates; each candidate within a margin of a hit is then
decided exactly: the ray's origin and direction and the vertices are f32 values, so
rational arithmetic (fractions.Fraction) gives the true sign of each edge function
and the true distance. Prints, per ray, every triangle the exact test hits, nearest
first, with t, the barycentrics and the triangle's area, and the triangles nearest
the ray's origin (the one it left: the bench offsets origins off the surface).
Standard library only; a few seconds a ray.
"""

import struct
import sys
from fractions import Fraction


def read_dump(path):
    with open(path, "rb") as f:
        data = f.read()
    nv, nt, nr, nb, _ = struct.unpack_from("<5I", data, 0)
    offset = 20
    verts = struct.unpack_from(f"<{3 * nv}f", data, offset)
    offset += 12 * nv
    tris = struct.unpack_from(f"<{3 * nt}I", data, offset)
    offset += 12 * nt
    rays = struct.unpack_from(f"<{6 * nr}f", data, offset)
    vertices = [verts[3 * i : 3 * i + 3] for i in range(nv)]
    triangles = [tris[3 * i : 3 * i + 3] for i in range(nt)]
    return vertices, triangles, rays, nr


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def moller_trumbore(o, d, a, b, c):
    """(t, u, v) of the ray's crossing of the triangle's plane, or None if parallel."""
    e1, e2 = sub(b, a), sub(c, a)
    p = cross(d, e2)
    det = dot(e1, p)
    if det == 0:
        return None
    s = sub(o, a)
    q = cross(s, e1)
    return dot(e2, q) / det, dot(s, p) / det, dot(d, q) / det


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    vertices, triangles, rays, nr = read_dump(sys.argv[1])
    for arg in sys.argv[2:]:
        index = int(arg)
        if not 0 <= index < nr:
            sys.exit(f"ray {index}: the dump has {nr} incoherent rays")
        o, d = rays[6 * index : 6 * index + 3], rays[6 * index + 3 : 6 * index + 6]
        print(f"ray {index}: origin {o} dir {d}")
        margin = 1e-9
        candidates = []
        near = []
        for k, tri in enumerate(triangles):
            a, b, c = (vertices[i] for i in tri)
            hit = moller_trumbore(o, d, a, b, c)
            if hit is not None:
                t, u, v = hit
                if t > -margin and u > -margin and v > -margin and u + v < 1 + margin:
                    candidates.append(k)
            centroid = [(a[j] + b[j] + c[j]) / 3 for j in range(3)]
            near.append((sum((centroid[j] - o[j]) ** 2 for j in range(3)), k))
        exact_hits = []
        of = [Fraction(x) for x in o]
        df = [Fraction(x) for x in d]
        for k in candidates:
            a, b, c = ([Fraction(x) for x in vertices[i]] for i in triangles[k])
            hit = moller_trumbore(of, df, a, b, c)
            if hit is None:
                continue
            t, u, v = hit
            if t > 0 and u >= 0 and v >= 0 and u + v <= 1:
                area = dot(cross(sub(b, a), sub(c, a)), cross(sub(b, a), sub(c, a)))
                exact_hits.append((t, k, u, v, float(area) ** 0.5 / 2))
        exact_hits.sort()
        if not exact_hits:
            print("  exact: no triangle is hit at t > 0")
        for t, k, u, v, area in exact_hits:
            print(
                f"  exact: hits triangle {k} at t {float(t):.9g} (u {float(u):.6g}, "
                f"v {float(v):.6g}, area {area:.3g} m²)"
            )
        near.sort()
        for dist2, k in near[:4]:
            a, b, c = (vertices[i] for i in triangles[k])
            n = cross(sub(b, a), sub(c, a))
            length = dot(n, n) ** 0.5
            n = tuple(x / length for x in n) if length else n
            plane = dot(n, sub(o, a))
            print(
                f"  near the origin: triangle {k}, centroid {dist2 ** 0.5:.3g} m away, "
                f"origin {plane:.3g} m off its plane, normal·dir {dot(n, d):.3g}"
            )


if __name__ == "__main__":
    main()
