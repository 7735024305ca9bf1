#!/usr/bin/env python3
"""Path-traced reference images of a glTF scene, rendered by Blender's Cycles on the CPU
(through the `bpy` wheel; nothing here shares code with Penumbra).

    python3 -m venv /opt/bpyenv && /opt/bpyenv/bin/pip install bpy==4.2.0
    /opt/bpyenv/bin/python tools/reference.py SCENE.gltf --out PREFIX [--size 256] \
        [--spp 256] [--bounces 0]

writes PREFIX.exr (linear RGB, half float: radiance in Penumbra's units, nits, the image
Penumbra's HDR target holds at its default exposure) and PREFIX.png (the same through Khronos
PBR Neutral and sRGB, as Penumbra displays it). `--bounces 0` is direct light only (the fair
comparison for a rasteriser); `--bounces 8` is full global illumination.

What Blender's glTF importer would get wrong, and what this script does instead (each measured;
see tests/reference/README.md):
- Lights are not taken from the importer. Its default lighting mode divides by 683, and even
  its compatibility mode leaves a 0.25 m radius, soft falloff and a spot blend that widens
  cones. Every KHR_lights_punctual light and every PENUMBRA_lights_area light is created here
  from the file's JSON: sun strength = lux (W/m² in Cycles' units, the 683 lm/W dropped on
  both sides), point and spot power = 4π·cd, radius 0, soft falloff off, sun angle 0; a spot's
  size is twice glTF's outer angle and its blend is refitted so the ramp spans the inner angle
  (Cycles' ramp is a smoothstep where glTF's is a square; the residual is documented);
  rectangles and disks get power π·A·L for face luminance L, and are invisible to camera rays
  (Penumbra does not draw emitters); sphere lights are point lights of radius r.
- glTF `range` is ignored (Cycles has none): Penumbra's window is one source of error the
  report measures.
- The camera is created from the file's JSON too (vertical field of view, near plane).
- KHR_materials_anisotropy: the importer passes the strength s to the Principled BSDF's own
  anisotropy, whose α pair is (α/a, α·a) with a = sqrt(1 - 0.9·anisotropic), not the
  extension's (mix(α, 1, s²), α). For a factor-only material the Principled roughness and
  anisotropy are set here so that Cycles' pair is the extension's (as far as anisotropic ≤ 1
  reaches: an aspect down to sqrt(0.1)).
- The world is black (the default world adds ambient light); the view transform is Standard
  (not AgX), no dithering, no denoising, no adaptive sampling, no clamping; the pixel filter
  is a 1-pixel box (Cycles' default is a 1.5-pixel Blackman-Harris), like a multisample resolve.
"""

import argparse
import json
import math
import os
import struct
import sys
import time
import zlib

import bpy
import numpy as np
from mathutils import Matrix, Quaternion, Vector

# glTF's Y-up to Blender's Z-up, as the importer converts: (x, y, z) -> (x, -z, y).
Y_UP_TO_Z_UP = Matrix(((1, 0, 0, 0), (0, 0, -1, 0), (0, 1, 0, 0), (0, 0, 0, 1)))


def read_gltf_json(path):
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] == b"glTF":
        length = struct.unpack("<I", data[12:16])[0]
        return json.loads(data[20 : 20 + length])
    return json.loads(data)


def node_matrix(node):
    if "matrix" in node:
        m = node["matrix"]
        return Matrix([[m[c * 4 + r] for c in range(4)] for r in range(4)])
    t = node.get("translation", [0, 0, 0])
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    s = node.get("scale", [1, 1, 1])
    return Matrix.Translation(Vector(t)) @ Quaternion((w, x, y, z)).to_matrix().to_4x4() @ Matrix.Diagonal(Vector(s + [1]))


def world_matrices(doc, scene_index):
    """Node index -> world matrix (glTF space) for every node of the scene."""
    out = {}

    def visit(i, parent):
        m = parent @ node_matrix(doc["nodes"][i])
        out[i] = m
        for c in doc["nodes"][i].get("children", []):
            visit(c, m)

    for root in doc["scenes"][scene_index]["nodes"]:
        visit(root, Matrix.Identity(4))
    return out


def placed(matrix):
    """The Blender world matrix of a light or camera on a glTF node: both point down local −Z
    with +Y up in either convention, so only the world axes change. Scale is dropped."""
    loc, rot, _ = (Y_UP_TO_Z_UP @ matrix).decompose()
    return Matrix.Translation(loc) @ rot.to_matrix().to_4x4()


def add_light(name, kind, matrix, color, setup):
    data = bpy.data.lights.new(name, kind)
    data.color = color
    setup(data)
    obj = bpy.data.objects.new(name, data)
    obj.matrix_world = placed(matrix)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def punctual(name, light, matrix):
    color = light.get("color", [1, 1, 1])
    intensity = light.get("intensity", 1.0)
    kind = light["type"]

    def sharp(d):
        d.shadow_soft_size = 0.0
        d.use_soft_falloff = False

    if kind == "directional":
        def sun(d):
            d.energy = intensity
            d.angle = 0.0
        add_light(name, "SUN", matrix, color, sun)
    elif kind == "point":
        def point(d):
            sharp(d)
            d.energy = 4 * math.pi * intensity
        add_light(name, "POINT", matrix, color, point)
    elif kind == "spot":
        spot = light.get("spot", {})
        inner = spot.get("innerConeAngle", 0.0)
        outer = spot.get("outerConeAngle", math.pi / 4)

        def spot_setup(d):
            sharp(d)
            d.energy = 4 * math.pi * intensity
            d.spot_size = 2 * outer
            # Cycles: smoothstep((cos θ − cos o) / ((1 − cos o)·blend)); the ramp ends at the
            # inner cone when blend = (cos i − cos o) / (1 − cos o).
            co, ci = math.cos(outer), math.cos(inner)
            d.spot_blend = min(max((ci - co) / max(1 - co, 1e-6), 0.0), 1.0)
            d.show_cone = False
        add_light(name, "SPOT", matrix, color, spot_setup)
    else:
        sys.exit(f"{name}: unknown light type {kind!r}")


def area(name, ext, matrix):
    color = ext.get("color", [1, 1, 1])
    shape = ext["shape"]
    if shape == "rect":
        w, h, lum = ext["width"], ext["height"], ext["luminance"]

        def rect(d):
            d.shape = "RECTANGLE"
            d.size, d.size_y = w, h
            d.energy = math.pi * w * h * lum
        obj = add_light(name, "AREA", matrix, color, rect)
    elif shape == "disk":
        r, lum = ext["radius"], ext["luminance"]

        def disk(d):
            d.shape = "DISK"
            d.size = 2 * r
            d.energy = math.pi * math.pi * r * r * lum
        obj = add_light(name, "AREA", matrix, color, disk)
    elif shape == "sphere":
        r, cd = ext["radius"], ext["intensity"]

        def ball(d):
            d.shadow_soft_size = r
            d.use_soft_falloff = False
            d.energy = 4 * math.pi * cd
        obj = add_light(name, "POINT", matrix, color, ball)
    else:
        sys.exit(f"{name}: Cycles has no {shape!r} light; leave it out of reference scenes")
    obj.visible_camera = False


def anisotropy_as_gltf(doc):
    """Gives each factor-only KHR_materials_anisotropy material the Principled roughness and
    anisotropy whose GGX α pair is the extension's (see the module docstring)."""
    for m in doc.get("materials", []):
        ext = m.get("extensions", {}).get("KHR_materials_anisotropy")
        if ext is None or "anisotropyTexture" in ext or "metallicRoughnessTexture" in m.get("pbrMetallicRoughness", {}):
            continue
        strength = ext.get("anisotropyStrength", 0.0)
        alpha = m.get("pbrMetallicRoughness", {}).get("roughnessFactor", 1.0) ** 2
        along = alpha + (1.0 - alpha) * strength * strength
        across = alpha
        # Blender: along = r² / a, across = r² · a, a = sqrt(1 - 0.9 · anisotropic).
        r2 = math.sqrt(along * across)
        aspect2 = across / along
        anisotropic = min((1.0 - aspect2) / 0.9, 1.0)
        mat = bpy.data.materials.get(m.get("name", ""))
        bsdf = mat and next((n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
        if bsdf is None:
            continue
        bsdf.inputs["Roughness"].default_value = math.sqrt(r2)
        bsdf.inputs["Anisotropic"].default_value = anisotropic


def pbr_neutral(c):
    """Khronos PBR Neutral, as shaders/tonemap.wgsl applies it."""
    start, desat = 0.8 - 0.04, 0.15
    x = c.min(axis=-1, keepdims=True)
    offset = np.where(x < 0.08, x - 6.25 * x * x, 0.04)
    c = c - offset
    peak = c.max(axis=-1, keepdims=True)
    d = 1.0 - start
    new_peak = 1.0 - d * d / (peak + d - start)
    scaled = c * (new_peak / np.maximum(peak, 1e-12))
    g = 1.0 - 1.0 / (desat * (peak - new_peak) + 1.0)
    compressed = scaled * (1 - g) + new_peak * g
    return np.where(peak < start, c, compressed)


def srgb(c):
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055)


def write_png(path, rgb8):
    h, w, _ = rgb8.shape
    raw = b"".join(b"\x00" + rgb8[y].tobytes() for y in range(h))
    chunk = lambda tag, data: struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("scene")
    p.add_argument("--out", required=True, help="output prefix: PREFIX.exr and PREFIX.png")
    p.add_argument("--size", default="256x256", help="WIDTHxHEIGHT")
    p.add_argument("--spp", type=int, default=256)
    p.add_argument("--bounces", type=int, default=0, help="0: direct light only")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--threads", type=int, default=0, help="0: all cores")
    args = p.parse_args()
    width, height = (int(v) for v in args.size.lower().split("x"))
    scene_path = os.path.abspath(args.scene)
    doc = read_gltf_json(scene_path)

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=scene_path, export_import_convert_lighting_mode="COMPAT")
    for obj in list(bpy.data.objects):
        if obj.type in ("LIGHT", "CAMERA"):
            bpy.data.objects.remove(obj, do_unlink=True)

    anisotropy_as_gltf(doc)
    scene = bpy.context.scene
    matrices = world_matrices(doc, doc.get("scene", 0))
    lights = doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    camera = None
    for i, m in matrices.items():
        node = doc["nodes"][i]
        name = node.get("name", f"node{i}")
        ext = node.get("extensions", {})
        if "KHR_lights_punctual" in ext:
            punctual(name, lights[ext["KHR_lights_punctual"]["light"]], m)
        if "PENUMBRA_lights_area" in ext:
            area(name, ext["PENUMBRA_lights_area"], m)
        if "camera" in node and camera is None:
            spec = doc["cameras"][node["camera"]]
            if spec["type"] != "perspective":
                sys.exit("only perspective cameras are supported")
            data = bpy.data.cameras.new("camera")
            data.sensor_fit = "VERTICAL"
            data.angle_y = spec["perspective"]["yfov"]
            data.clip_start = spec["perspective"].get("znear", 0.05)
            data.clip_end = spec["perspective"].get("zfar", 1e5)
            camera = bpy.data.objects.new("camera", data)
            camera.matrix_world = placed(m)
            scene.collection.objects.link(camera)
    if camera is None:
        sys.exit(f"{args.scene}: the scene has no camera")
    scene.camera = camera

    world = bpy.data.worlds.new("black")
    world.use_nodes = False
    world.color = (0, 0, 0)
    scene.world = world

    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    cy.samples = args.spp
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.seed = args.seed
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.max_bounces = args.bounces
    cy.diffuse_bounces = args.bounces
    cy.glossy_bounces = args.bounces
    cy.transmission_bounces = args.bounces
    cy.volume_bounces = 0
    cy.transparent_max_bounces = 8
    cy.caustics_reflective = args.bounces > 0
    cy.caustics_refractive = args.bounces > 0
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    if args.threads:
        scene.render.threads_mode = "FIXED"
        scene.render.threads = args.threads
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    scene.render.dither_intensity = 0.0
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    settings = scene.render.image_settings
    settings.file_format = "OPEN_EXR"
    settings.color_mode = "RGB"
    settings.color_depth = "16"
    settings.exr_codec = "ZIP"

    exr = os.path.abspath(args.out + ".exr")
    scene.render.filepath = exr
    start = time.time()
    bpy.ops.render.render(write_still=True)
    seconds = time.time() - start

    img = bpy.data.images.load(exr)
    px = np.array(img.pixels[:], dtype=np.float32).reshape(height, width, img.channels)[::-1, :, :3]
    write_png(os.path.abspath(args.out + ".png"), (srgb(pbr_neutral(px.astype(np.float64))) * 255 + 0.5).astype(np.uint8))
    print(
        f"{args.scene}: {width}x{height}, {args.spp} spp, {args.bounces} bounces, "
        f"{seconds:.1f} s, mean radiance {px.mean():.4f}, max {px.max():.3f} -> {exr}"
    )


if __name__ == "__main__":
    main()
    # bpy 4.2 crashes in its own teardown at interpreter exit, after everything is written.
    sys.stdout.flush()
    os._exit(0)
