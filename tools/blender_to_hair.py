#!/usr/bin/env python3
"""Writes a Blender hair curves object as a .hair file (Cem Yuksel's format) that dualhair reads.

An export path for hair made in Blender beside USD (dualhair reads no Alembic: docs/usage.md, "Hair
formats: in and out"). Takes a Curves object (Blender's hair system since 3.3, including hair made with the
procedural hair node assets: modifiers are applied), in world space: each curve is a strand of its
control points (the renderer joins them with straight pieces; for smooth curves, resample them in
Blender first, e.g. with the Resample Curves node), its thickness is twice the `radius` attribute
(or `--radius` where the object has none), scaled with the object.

With Blender:   blender -b scene.blend --python tools/blender_to_hair.py -- OUT.hair [--object NAME] [--radius R]
With bpy (PyPI): python tools/blender_to_hair.py OUT.hair --blend scene.blend [--object NAME] [--radius R]

Without --object, the active object, else the only Curves object of the scene.
"""
import argparse
import struct
import sys

import bpy
from mathutils import Vector

# Header flags of the arrays written (hair_format.rs): segments, points, thickness.
SEGMENTS, POINTS, THICKNESS = 1, 2, 4


def hair_object(name):
    """The Curves object to export."""
    if name:
        obj = bpy.data.objects.get(name)
        if obj is None or obj.type != "CURVES":
            sys.exit(f"blender_to_hair: no hair curves object named {name!r}")
        return obj
    active = bpy.context.view_layer.objects.active
    if active is not None and active.type == "CURVES":
        return active
    found = [o for o in bpy.context.scene.objects if o.type == "CURVES"]
    if len(found) != 1:
        sys.exit(f"blender_to_hair: {len(found)} hair curves objects in the scene; name one with --object")
    return found[0]


def strands(obj, default_radius):
    """(points per strand, world positions, radii) of the evaluated object."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    curves = obj.evaluated_get(depsgraph).data
    n_points, n_curves = len(curves.points), len(curves.curves)
    offsets = [0] * (n_curves + 1)
    curves.curve_offset_data.foreach_get("value", offsets)
    counts = [offsets[i + 1] - offsets[i] for i in range(n_curves)]
    flat = [0.0] * (3 * n_points)
    curves.attributes["position"].data.foreach_get("vector", flat)
    if "radius" in curves.attributes:
        radii = [0.0] * n_points
        curves.attributes["radius"].data.foreach_get("value", radii)
    elif default_radius is not None:
        radii = [default_radius] * n_points
    else:
        sys.exit(f"blender_to_hair: {obj.name} has no radius attribute; give --radius")
    matrix = obj.matrix_world
    scale = abs(matrix.determinant()) ** (1.0 / 3.0)
    points = [matrix @ Vector(flat[3 * i : 3 * i + 3]) for i in range(n_points)]
    return counts, points, [r * scale for r in radii]


def write_hair(path, counts, points, radii, info):
    """The .hair file: a 128-byte header, then segments (u16), points (f32 xyz), thickness (f32)."""
    if any(c < 2 for c in counts):
        sys.exit("blender_to_hair: a curve with fewer than 2 points")
    if any(c - 1 > 0xFFFF for c in counts):
        sys.exit("blender_to_hair: a curve with more than 65,536 points (the format's limit)")
    header = b"HAIR" + struct.pack("<IIIIff3f", len(counts), len(points), SEGMENTS | POINTS | THICKNESS, 0, 1.0, 0.0, 0, 0, 0)
    header += info.encode()[:87].ljust(88, b"\0")
    with open(path, "wb") as f:
        f.write(header)
        f.write(struct.pack(f"<{len(counts)}H", *[c - 1 for c in counts]))
        f.write(struct.pack(f"<{3 * len(points)}f", *[x for p in points for x in p]))
        f.write(struct.pack(f"<{len(radii)}f", *[2.0 * r for r in radii]))


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output", help="the .hair file to write")
    parser.add_argument("--blend", help="a .blend file to open first (with the bpy module)")
    parser.add_argument("--object", help="the hair curves object (default: the active or only one)")
    parser.add_argument("--radius", type=float, help="fiber radius where the object has no radius attribute")
    args = parser.parse_args(argv)
    if args.blend:
        bpy.ops.wm.open_mainfile(filepath=args.blend)
    obj = hair_object(args.object)
    counts, points, radii = strands(obj, args.radius)
    write_hair(args.output, counts, points, radii, f"Blender {bpy.app.version_string}: {obj.name}")
    print(f"wrote {args.output}: {len(counts)} strands, {len(points)} points from {obj.name}")


if __name__ == "__main__":
    # Under `blender --python`, the script's arguments follow `--`.
    main(sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:])
