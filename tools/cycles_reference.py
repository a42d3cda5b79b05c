#!/usr/bin/env python3
"""Render a dualhair scene with Blender Cycles, as an independent reference for `dualhair render`.

Needs the `bpy` package (PyPI bpy 5.2.x, which needs Python 3.13) and numpy:

    python3.13 -m venv .venv-cycles && .venv-cycles/bin/pip install "bpy>=5.2,<5.3" numpy
    .venv-cycles/bin/python tools/cycles_reference.py scenes/brown.json -o cycles.exr --spp 256

The scene is first written out by `dualhair resolve` (hair as a .hair file in world units after its
transform, the framed camera, the fiber's sigma_a), then rebuilt in Cycles:

- strands: one hair-curves object of linear (POLY) curves with the per-point radius, rendered as
  3D curves, so each segment is a tapered cylinder with round joints (dualhair: capsules with the
  mean radius of their two points; the two differ by far less than a pixel at these point densities);
- fiber: Principled Hair BSDF, Chiang model, absorption coefficient = sigma_a (both per unit fiber
  radius), Roughness = beta_m, Radial Roughness = beta_n, IOR = eta, Offset = alpha (the same sign:
  both put the R lobe toward the root; pbrt-v3/v4 use the opposite sign), Coat = 0, no randomness;
- camera: the same pinhole, vertical field of view, resolution; box pixel filter one pixel wide;
- environment: a constant color, or the lat-long map (Cycles' Environment Texture, equirectangular)
  turned by `rotation` degrees about +Z with a Mapping node; strength multiplies it;
- sun: a Sun light whose +Z points toward the sun, Strength = irradiance (W/m^2 on a surface facing
  it), Angle = angular diameter;
- film: transparent (alpha = hair coverage, as dualhair's A), no denoising, no clamping, no light
  tree, no adaptive sampling, no filter glossy, caustics on, `--max-bounces` bounces of every kind
  (default 1024, Cycles' most: dualhair's path tracer ends paths by Russian roulette only);
- output: linear 32-bit float EXR with R, G, B, A (no view transform is applied to EXR).

Prints the render time (BVH build and sampling, from Cycles' own statistics) on stdout as JSON.
Compare with `dualhair compare OURS.exr cycles.exr`.
"""

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np


def read_hair(path):
    """Strands of a .hair file (Cem Yuksel's format): list of point arrays and of radius arrays."""
    data = open(path, "rb").read()
    if len(data) < 128 or data[:4] != b"HAIR":
        sys.exit(f"{path}: not a .hair file")
    strands, points, flags, default_segments = np.frombuffer(data, "<u4", 4, 4)
    default_thickness = np.frombuffer(data, "<f4", 1, 20)[0]
    offset = 128
    if flags & 1:
        segments = np.frombuffer(data, "<u2", strands, offset).astype(np.int64)
        offset += 2 * strands
    else:
        segments = np.full(strands, default_segments, np.int64)
    if not flags & 2:
        sys.exit(f"{path}: the file has no point array")
    positions = np.frombuffer(data, "<f4", 3 * points, offset).reshape(points, 3)
    offset += 12 * points
    if flags & 4:
        thickness = np.frombuffer(data, "<f4", points, offset)
    else:
        thickness = np.full(points, default_thickness, np.float32)
    sizes = segments + 1
    if sizes.sum() != points:
        sys.exit(f"{path}: segment counts do not add up to the point count")
    return sizes, positions, 0.5 * thickness


def look_at_matrix(position, look_at, up):
    """World matrix of a Blender camera (it looks along its local -Z, local +Y up)."""
    import mathutils

    forward = (mathutils.Vector(look_at) - mathutils.Vector(position)).normalized()
    right = forward.cross(mathutils.Vector(up)).normalized()
    true_up = right.cross(forward)
    rot = mathutils.Matrix((right, true_up, -forward)).transposed().to_4x4()
    rot.translation = mathutils.Vector(position)
    return rot


def z_toward(direction):
    """A rotation taking local +Z to `direction` (a Blender sun shines along its local -Z)."""
    import mathutils

    return mathutils.Vector(direction).normalized().to_track_quat("Z", "Y").to_matrix().to_4x4()


def build_scene(scene, hair_path, spp, seed, threads, max_bounces):
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    s = bpy.context.scene
    s.render.engine = "CYCLES"
    c = s.cycles
    c.device = "CPU"
    c.samples = spp
    c.seed = seed
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.use_light_tree = False
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.blur_glossy = 0.0
    c.caustics_reflective = True
    c.caustics_refractive = True
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    for name in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces",
                 "volume_bounces", "transparent_max_bounces"):
        setattr(c, name, max_bounces)
    s.render.film_transparent = True
    s.render.hair_type = "STRAND"
    s.render.hair_subdiv = 0
    cam = scene["camera"]
    s.render.resolution_x, s.render.resolution_y = cam["width"], cam["height"]
    s.render.resolution_percentage = 100
    if threads:
        s.render.threads_mode = "FIXED"
        s.render.threads = threads
    s.view_settings.view_transform = "Standard"
    s.view_settings.look = "None"
    s.view_settings.exposure = 0.0
    s.view_settings.gamma = 1.0
    s.render.image_settings.file_format = "OPEN_EXR"
    s.render.image_settings.color_mode = "RGBA"
    s.render.image_settings.color_depth = "32"
    s.render.image_settings.exr_codec = "ZIP"

    # Camera.
    cam_data = bpy.data.cameras.new("camera")
    cam_data.sensor_fit = "VERTICAL"
    cam_data.angle_y = math.radians(cam["fov"])
    cam_data.clip_start = 1e-4
    cam_data.clip_end = 1e6
    cam_obj = bpy.data.objects.new("camera", cam_data)
    cam_obj.matrix_world = look_at_matrix(cam["position"], cam["look_at"], cam["up"])
    s.collection.objects.link(cam_obj)
    s.camera = cam_obj

    # Hair.
    sizes, positions, radii = read_hair(hair_path)
    curves = bpy.data.hair_curves.new("hair")
    curves.add_curves(sizes.tolist())
    curves.set_types(type="POLY")
    curves.attributes["position"].data.foreach_set("vector", positions.ravel())
    radius = curves.attributes.get("radius") or curves.attributes.new("radius", "FLOAT", "POINT")
    radius.data.foreach_set("value", radii)
    hair_obj = bpy.data.objects.new("hair", curves)
    s.collection.objects.link(hair_obj)

    # Fiber.
    fiber = scene["fiber"]
    mat = bpy.data.materials.new("fiber")
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    bsdf = nodes.new("ShaderNodeBsdfHairPrincipled")
    bsdf.model = "CHIANG"
    bsdf.parametrization = "ABSORPTION"
    sigma_a = fiber["absorption"]["sigma_a"]
    bsdf.inputs["Absorption Coefficient"].default_value = (*sigma_a,)
    bsdf.inputs["Roughness"].default_value = fiber["beta_m"]
    bsdf.inputs["Radial Roughness"].default_value = fiber["beta_n"]
    bsdf.inputs["Coat"].default_value = 0.0
    bsdf.inputs["IOR"].default_value = fiber["eta"]
    bsdf.inputs["Offset"].default_value = math.radians(fiber["alpha"])
    bsdf.inputs["Random Roughness"].default_value = 0.0  # ("Random Color" is for melanin only)
    out = nodes.new("ShaderNodeOutputMaterial")
    links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    curves.materials.append(mat)

    # Lights.
    lights = scene.get("lights", {})
    world = bpy.data.worlds.new("world")
    s.world = world
    wn, wl = world.node_tree.nodes, world.node_tree.links
    wn.clear()
    background = wn.new("ShaderNodeBackground")
    wl.new(background.outputs["Background"], wn.new("ShaderNodeOutputWorld").inputs["Surface"])
    env = lights.get("environment")
    if env is None:
        background.inputs["Strength"].default_value = 0.0
    elif env.get("file"):
        tex = wn.new("ShaderNodeTexEnvironment")
        tex.image = bpy.data.images.load(env["file"])
        tex.image.colorspace_settings.name = "Linear Rec.709"
        tex.interpolation = "Closest"
        if env.get("rotation", 0.0) != 0.0:
            mapping = wn.new("ShaderNodeMapping")
            mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(env.get("rotation", 0.0)))
            coords = wn.new("ShaderNodeTexCoord")
            wl.new(coords.outputs["Generated"], mapping.inputs["Vector"])
            wl.new(mapping.outputs["Vector"], tex.inputs["Vector"])
        wl.new(tex.outputs["Color"], background.inputs["Color"])
        background.inputs["Strength"].default_value = env.get("strength", 1.0)
    else:
        color = env.get("color", [1.0, 1.0, 1.0])
        background.inputs["Color"].default_value = (*color, 1.0)
        background.inputs["Strength"].default_value = env.get("strength", 1.0)
    sun = lights.get("sun")
    if sun is not None:
        irradiance = sun["irradiance"]
        rgb = irradiance if isinstance(irradiance, list) else [irradiance] * 3
        peak = max(rgb)
        sun_data = bpy.data.lights.new("sun", "SUN")
        sun_data.energy = peak
        sun_data.color = [v / peak for v in rgb] if peak > 0 else [1.0, 1.0, 1.0]
        sun_data.angle = math.radians(sun.get("angular_diameter", 0.53))
        sun_obj = bpy.data.objects.new("sun", sun_data)
        sun_obj.matrix_world = z_toward(sun["direction"])
        s.collection.objects.link(sun_obj)
    return s


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene", help="dualhair scene file (.json) or .hair file")
    ap.add_argument("-o", "--output", required=True, help="output EXR")
    ap.add_argument("--spp", type=int, help="samples per pixel (default: the scene's)")
    ap.add_argument("--width", type=int, help="image width (default: the scene's)")
    ap.add_argument("--height", type=int, help="image height (default: the scene's)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=0, help="CPU threads (default: all)")
    ap.add_argument("--max-bounces", type=int, default=1024)
    ap.add_argument("--dualhair", default=None,
                    help="the dualhair binary (default: target/release/dualhair, else on PATH)")
    args = ap.parse_args()

    binary = args.dualhair
    if binary is None:
        here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "target", "release", "dualhair")
        binary = here if os.path.exists(here) else shutil.which("dualhair")
    if binary is None:
        sys.exit("cannot find the dualhair binary: build it (cargo build --release) or pass --dualhair")

    with tempfile.TemporaryDirectory(prefix="dualhair-cycles-") as tmp:
        overrides = []
        resolved = subprocess.run([binary, "resolve", args.scene, "-o", tmp], capture_output=True, text=True)
        if resolved.returncode != 0:
            sys.exit(resolved.stderr.strip())
        scene = json.load(open(os.path.join(tmp, "scene.json")))
        cam = scene["camera"]
        if args.width:
            cam["width"] = args.width
            overrides.append("width")
        if args.height:
            cam["height"] = args.height
            overrides.append("height")
        spp = args.spp or scene.get("render", {}).get("spp", 16)
        s = build_scene(scene, os.path.join(tmp, "hair.hair"), spp, args.seed, args.threads, args.max_bounces)
        import bpy

        out = os.path.abspath(args.output)
        partial = os.path.join(os.path.dirname(out), "." + os.path.basename(out) + ".partial.exr")
        s.render.filepath = partial
        start = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        seconds = time.perf_counter() - start
        os.replace(partial, out)
    print(json.dumps({"output": out, "spp": spp, "width": cam["width"], "height": cam["height"],
                      "render_seconds": round(seconds, 3), "blender": bpy.app.version_string}))


if __name__ == "__main__":
    main()
