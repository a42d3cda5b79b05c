#!/usr/bin/env python3
"""Writes scenes/groom/head.obj: a simple head under the scalp of the bundled wavy_short groom.

The groom's roots lie on an ellipsoid centred at the origin with semi-axes (1.0, 1.15, 1.1)
(fitted to the 30,033 roots by least squares: every root within 0.1% of it). The head is that
ellipsoid shrunk by 1.5%, so roots sit just above the skin, plus a jaw, a chin, a neck, a nose and two
ears made of smaller ellipsoids (Z up, the face toward -Y, as the groom). Closed ellipsoids may overlap: the
renderer's surfaces are two-sided and rays stop at the first one. Python 3 only, no packages.

    python3 tools/make_head.py scenes/groom/head.obj
"""
import math
import sys

# (center, semi-axes) of each part, in the groom's units.
PARTS = [
    ((0.0, 0.0, 0.0), (0.985, 1.133, 1.083)),  # cranium, under the scalp
    ((0.0, -0.3, -0.62), (0.8, 0.85, 0.72)),  # jaw and cheeks
    ((0.0, -0.78, -1.05), (0.3, 0.28, 0.22)),  # chin
    ((0.0, 0.1, -1.45), (0.45, 0.47, 0.8)),  # neck
    ((0.0, -1.12, -0.42), (0.1, 0.16, 0.24)),  # nose
    ((-0.97, 0.12, -0.35), (0.05, 0.15, 0.24)),  # ears
    ((0.97, 0.12, -0.35), (0.05, 0.15, 0.24)),
]
RINGS, SEGMENTS = 24, 48


def ellipsoid(center, axes, first):
    """Vertices (pole to pole, ring by ring) and 1-based triangle faces of a UV ellipsoid."""
    vertices = [(center[0], center[1], center[2] + axes[2])]
    for i in range(1, RINGS):
        theta = math.pi * i / RINGS
        for j in range(SEGMENTS):
            phi = 2 * math.pi * j / SEGMENTS
            x, y, z = math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)
            vertices.append(tuple(c + a * u for c, a, u in zip(center, axes, (x, y, z))))
    vertices.append((center[0], center[1], center[2] - axes[2]))
    ring = lambda i, j: first + 1 + (i - 1) * SEGMENTS + j % SEGMENTS
    south = first + len(vertices) - 1
    faces = [(first, ring(1, j + 1), ring(1, j)) for j in range(SEGMENTS)]
    for i in range(1, RINGS - 1):
        for j in range(SEGMENTS):
            a, b, c, d = ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j)
            faces += [(a, b, c), (a, c, d)]
    faces += [(south, ring(RINGS - 1, j), ring(RINGS - 1, j + 1)) for j in range(SEGMENTS)]
    return vertices, faces


def main(out):
    lines = ["# A simple head under the scalp of scenes/groom/wavy_short.hair.gz (tools/make_head.py)"]
    count = 1
    for center, axes in PARTS:
        vertices, faces = ellipsoid(center, axes, count)
        lines += ["v %.5f %.5f %.5f" % v for v in vertices]
        lines += ["f %d %d %d" % f for f in faces]
        count += len(vertices)
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "scenes/groom/head.obj")
