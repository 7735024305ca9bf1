#!/usr/bin/env python3
"""Writes the reference scene suite: small glTF files that Penumbra renders and that
tools/reference.py path-traces with Blender's Cycles. Pure Python (no dependencies), so the
scenes can be regenerated anywhere:

    python3 tools/make_reference_scenes.py

Writes tests/reference/scenes/{spheres,cornell,sun_csm,area}.gltf (geometry in data URIs) and
tests/assets/DamagedHelmet/DamagedHelmetLit.gltf (the helmet's own .glb as its buffer, with a
sun, two point lights and a camera added; it sits beside the .glb so it reads nothing outside
its folder). Units are glTF's: metres, lux for the sun, candela for point lights; area lights
use the PENUMBRA_lights_area node extension (cd/m² of the emitting face).
"""

import base64
import json
import math
import os
import struct

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
SCENES = os.path.join(ROOT, "tests", "reference", "scenes")


class Builder:
    """Accumulates one glTF document with a single embedded buffer."""

    def __init__(self):
        self.buf = bytearray()
        self.doc = {
            "asset": {"version": "2.0", "generator": "penumbra tools/make_reference_scenes.py"},
            "scene": 0,
            "scenes": [{"nodes": []}],
            "nodes": [],
            "meshes": [],
            "materials": [],
            "accessors": [],
            "bufferViews": [],
            "buffers": [],
        }
        self.lights = []

    def _view(self, data, target):
        while len(self.buf) % 4:
            self.buf.append(0)
        self.doc["bufferViews"].append(
            {"buffer": 0, "byteOffset": len(self.buf), "byteLength": len(data), "target": target}
        )
        self.buf += data
        return len(self.doc["bufferViews"]) - 1

    def geometry(self, positions, normals, indices, uvs=None):
        """Accessors for a triangle list (with TEXCOORD_0 if `uvs`); returns the primitive's
        attribute dict and indices."""
        prim = self._geometry(positions, normals, indices)
        if uvs is not None:
            uv = self._view(b"".join(struct.pack("<2f", *t) for t in uvs), 34962)
            self.doc["accessors"].append({"bufferView": uv, "componentType": 5126, "count": len(uvs), "type": "VEC2"})
            prim["attributes"]["TEXCOORD_0"] = len(self.doc["accessors"]) - 1
        return prim

    def _geometry(self, positions, normals, indices):
        pv = self._view(b"".join(struct.pack("<3f", *p) for p in positions), 34962)
        nv = self._view(b"".join(struct.pack("<3f", *n) for n in normals), 34962)
        iv = self._view(b"".join(struct.pack("<I", i) for i in indices), 34963)
        lo = [min(p[k] for p in positions) for k in range(3)]
        hi = [max(p[k] for p in positions) for k in range(3)]
        acc = self.doc["accessors"]
        acc.append({"bufferView": pv, "componentType": 5126, "count": len(positions), "type": "VEC3", "min": lo, "max": hi})
        acc.append({"bufferView": nv, "componentType": 5126, "count": len(normals), "type": "VEC3"})
        acc.append({"bufferView": iv, "componentType": 5125, "count": len(indices), "type": "SCALAR"})
        n = len(acc)
        return {"attributes": {"POSITION": n - 3, "NORMAL": n - 2}, "indices": n - 1}

    def material(self, name, color, metallic=0.0, roughness=0.8, extensions=None, **fields):
        m = {
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": list(color) + [1.0],
                "metallicFactor": metallic,
                "roughnessFactor": roughness,
            },
        }
        if extensions:
            m["extensions"] = extensions
            used = self.doc.setdefault("extensionsUsed", [])
            used += [e for e in extensions if e not in used]
        m.update(fields)
        self.doc["materials"].append(m)
        return len(self.doc["materials"]) - 1

    def node(self, node):
        self.doc["nodes"].append(node)
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]) - 1)
        return len(self.doc["nodes"]) - 1

    def mesh_node(self, name, geom, material, translation=(0, 0, 0), rotation=None, scale=None):
        self.doc["meshes"].append({"name": name, "primitives": [dict(geom, material=material)]})
        node = {"name": name, "mesh": len(self.doc["meshes"]) - 1, "translation": list(translation)}
        if rotation:
            node["rotation"] = list(rotation)
        if scale:
            node["scale"] = list(scale)
        return self.node(node)

    def light(self, name, light, translation, rotation=None):
        self.lights.append(light)
        node = {"name": name, "translation": list(translation), "extensions": {"KHR_lights_punctual": {"light": len(self.lights) - 1}}}
        if rotation:
            node["rotation"] = list(rotation)
        return self.node(node)

    def camera(self, eye, target, yfov_deg, znear=0.05):
        self.doc["cameras"] = [{"type": "perspective", "perspective": {"yfov": math.radians(yfov_deg), "znear": znear, "aspectRatio": 1.0}}]
        return self.node({"name": "camera", "camera": 0, "translation": list(eye), "rotation": look_rotation(eye, target)})

    def write(self, path):
        doc = self.doc
        doc["buffers"] = [
            {"byteLength": len(self.buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(self.buf)).decode()}
        ]
        if self.lights:
            doc["extensionsUsed"] = sorted(set(doc.get("extensionsUsed", []) + ["KHR_lights_punctual"]))
            doc["extensions"] = {"KHR_lights_punctual": {"lights": self.lights}}
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w") as f:
            json.dump(doc, f, indent=1)
        print(f"wrote {os.path.relpath(path, ROOT)} ({os.path.getsize(path) // 1024} KiB)")


# --- maths -----------------------------------------------------------------------------------


def norm(v):
    length = math.sqrt(sum(x * x for x in v))
    return [x / length for x in v]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def quat_from_basis(x, y, z):
    """Unit quaternion (x, y, z, w) of the rotation whose columns are the axes x, y, z."""
    m = [[x[0], y[0], z[0]], [x[1], y[1], z[1]], [x[2], y[2], z[2]]]
    t = m[0][0] + m[1][1] + m[2][2]
    if t > 0:
        s = math.sqrt(t + 1.0) * 2
        q = [(m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, 0.25 * s]
    elif m[0][0] > m[1][1] and m[0][0] > m[2][2]:
        s = math.sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]) * 2
        q = [0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s]
    elif m[1][1] > m[2][2]:
        s = math.sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]) * 2
        q = [(m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s]
    else:
        s = math.sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]) * 2
        q = [(m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s, (m[1][0] - m[0][1]) / s]
    return norm(q)


def look_rotation(eye, target, up=(0, 1, 0)):
    """Rotation that points local −Z from `eye` at `target` (cameras and lights in glTF)."""
    f = norm([t - e for t, e in zip(target, eye)])
    if abs(sum(a * b for a, b in zip(f, up))) > 0.999:
        up = (0, 0, -1)
    x = norm(cross(f, up))
    y = cross(x, f)
    return quat_from_basis(x, y, [-c for c in f])


def axis_angle(axis, deg):
    a = math.radians(deg) / 2
    axis = norm(axis)
    return [axis[0] * math.sin(a), axis[1] * math.sin(a), axis[2] * math.sin(a), math.cos(a)]


# --- meshes ----------------------------------------------------------------------------------


def sphere_uv(radius, sectors=48, stacks=24):
    """`sphere` with longitude and latitude as UVs (u along the equator: its tangent)."""
    pos, nrm, idx = sphere(radius, sectors, stacks)
    uvs = [[j / sectors, i / stacks] for i in range(stacks + 1) for j in range(sectors + 1)]
    return pos, nrm, idx, uvs


def sphere(radius, sectors=48, stacks=24):
    pos, nrm, idx = [], [], []
    for i in range(stacks + 1):
        theta = math.pi * i / stacks
        for j in range(sectors + 1):
            phi = 2 * math.pi * j / sectors
            n = [math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi)]
            nrm.append(n)
            pos.append([radius * c for c in n])
    for i in range(stacks):
        for j in range(sectors):
            a = i * (sectors + 1) + j
            b = a + sectors + 1
            if i != 0:
                idx += [a, a + 1, b]
            if i != stacks - 1:
                idx += [a + 1, b + 1, b]
    return pos, nrm, idx


def box(sx, sy, sz):
    pos, nrm, idx = [], [], []
    h = [sx / 2, sy / 2, sz / 2]
    for axis in range(3):
        for sign in (-1, 1):
            n = [0, 0, 0]
            n[axis] = sign
            u = [0, 0, 0]
            v = [0, 0, 0]
            u[(axis + 1) % 3] = 1
            v[(axis + 2) % 3] = 1
            base = len(pos)
            for du, dv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [n[k] * h[k] + du * u[k] * h[k] + dv * v[k] * h[k] for k in range(3)]
                pos.append(p)
                nrm.append(n)
            # Counter-clockwise seen from outside: u × v = ±n.
            if sign > 0:
                idx += [base, base + 1, base + 2, base, base + 2, base + 3]
            else:
                idx += [base, base + 2, base + 1, base, base + 3, base + 2]
    return pos, nrm, idx


def quad(size_x, size_z, normal_sign=1):
    """A square in the XZ plane facing +Y (or −Y)."""
    hx, hz = size_x / 2, size_z / 2
    pos = [[-hx, 0, -hz], [hx, 0, -hz], [hx, 0, hz], [-hx, 0, hz]]
    nrm = [[0, normal_sign, 0]] * 4
    idx = [0, 2, 1, 0, 3, 2] if normal_sign > 0 else [0, 1, 2, 0, 2, 3]
    return pos, nrm, idx


# --- scenes ----------------------------------------------------------------------------------


def spheres():
    """Metallic (rows 0, 0.5, 1) × roughness (columns 0.1 to 1) spheres under a sun and a point
    light, on black: the BRDF alone, no shadows on anything but the spheres themselves."""
    b = Builder()
    geom = b.geometry(*sphere(0.42))
    for row, metallic in enumerate([0.0, 0.5, 1.0]):
        for col, rough in enumerate([0.1, 0.3, 0.5, 0.7, 1.0]):
            m = b.material(f"m{metallic}_r{rough}", (0.9, 0.55, 0.25), metallic, rough)
            b.mesh_node(f"sphere_m{metallic}_r{rough}", geom, m, (col - 2.0, 1.0 - row, 0.0))
    b.light("sun", {"type": "directional", "intensity": 2.5}, (0, 0, 0), look_rotation((0, 0, 0), (-0.4, -0.5, -1.0)))
    b.light("point", {"type": "point", "intensity": 6.0, "color": [1.0, 0.9, 0.8]}, (2.5, 2.0, 2.5))
    b.camera((0, 0, 6.3), (0, 0, 0), 40)
    b.write(os.path.join(SCENES, "spheres.gltf"))


def cornell():
    """A Cornell-like room (red left wall, green right, open front) with two boxes, lit by one
    point light under the ceiling: point-light shadows and inverse-square falloff."""
    b = Builder()
    white = b.material("white", (0.73, 0.73, 0.73), 0.0, 0.9)
    red = b.material("red", (0.63, 0.065, 0.05), 0.0, 0.9)
    green = b.material("green", (0.14, 0.45, 0.09), 0.0, 0.9)
    wall = b.geometry(*quad(2.0, 2.0))
    b.mesh_node("floor", wall, white, (0, 0, 0))
    b.mesh_node("ceiling", wall, white, (0, 2, 0), axis_angle((1, 0, 0), 180))
    b.mesh_node("back", wall, white, (0, 1, -1), axis_angle((1, 0, 0), 90))
    b.mesh_node("left", wall, red, (-1, 1, 0), axis_angle((0, 0, 1), -90))
    b.mesh_node("right", wall, green, (1, 1, 0), axis_angle((0, 0, 1), 90))
    b.mesh_node("tall_box", b.geometry(*box(0.6, 1.2, 0.6)), white, (-0.33, 0.6, -0.3), axis_angle((0, 1, 0), 18))
    b.mesh_node("short_box", b.geometry(*box(0.6, 0.6, 0.6)), white, (0.35, 0.3, 0.3), axis_angle((0, 1, 0), -17))
    b.light("lamp", {"type": "point", "intensity": 5.0, "color": [1.0, 0.85, 0.7]}, (0.0, 1.8, 0.1))
    b.camera((0, 1, 3.9), (0, 1, 0), 38)
    b.write(os.path.join(SCENES, "cornell.gltf"))


def sun_csm():
    """A 200 m ground under a low sun, with boxes and spheres from 2 m to 60 m away: shadows from
    every cascade, and their resolution against distance."""
    b = Builder()
    ground = b.material("ground", (0.5, 0.5, 0.45), 0.0, 0.9)
    b.mesh_node("ground", b.geometry(*quad(200.0, 200.0)), ground, (0, 0, 0))
    cube = b.geometry(*box(1, 1, 1))
    ball = b.geometry(*sphere(0.5, 32, 16))
    colours = [(0.8, 0.2, 0.15), (0.2, 0.5, 0.8), (0.85, 0.75, 0.3), (0.3, 0.7, 0.35)]
    mats = [b.material(f"c{i}", c, 0.0, 0.6) for i, c in enumerate(colours)]
    for i, d in enumerate([2.5, 5, 9, 15, 25, 40, 60]):
        x = (-1.2 if i % 2 else 1.2) * (1 + d / 12)
        s = 0.6 + d / 30
        b.mesh_node(f"box{i}", cube, mats[i % 4], (x, s / 2, -d), axis_angle((0, 1, 0), 25 * i), (s, s, s))
        b.mesh_node(f"ball{i}", ball, mats[(i + 1) % 4], (-x * 0.6, s * 0.6, -d - 1.5), None, (s * 1.2, s * 1.2, s * 1.2))
    b.mesh_node("post", cube, mats[2], (0.3, 1.0, -3.5), None, (0.15, 2.0, 0.15))
    b.light("sun", {"type": "directional", "intensity": 3.0, "color": [1.0, 0.95, 0.88]}, (0, 0, 0),
            look_rotation((0, 0, 0), (-0.55, -0.42, 0.5)))
    b.camera((0, 1.7, 1.5), (0, 0.6, -12), 55, 0.1)
    b.write(os.path.join(SCENES, "sun_csm.gltf"))


def area():
    """A floor, a sphere and a box lit by a rectangle, a disk and a sphere light (the
    PENUMBRA_lights_area extension): soft shadows and broad highlights."""
    b = Builder()
    floor = b.material("floor", (0.7, 0.7, 0.7), 0.0, 0.6)
    shiny = b.material("shiny", (0.95, 0.6, 0.3), 1.0, 0.25)
    matte = b.material("matte", (0.25, 0.45, 0.8), 0.0, 0.5)
    b.mesh_node("floor", b.geometry(*quad(8.0, 8.0)), floor, (0, 0, 0))
    b.mesh_node("ball", b.geometry(*sphere(0.5)), shiny, (-0.6, 0.5, 0))
    b.mesh_node("block", b.geometry(*box(0.7, 0.9, 0.7)), matte, (0.75, 0.45, -0.2), axis_angle((0, 1, 0), 30))

    def area_node(name, ext, eye, target):
        b.doc.setdefault("extensionsUsed", [])
        if "PENUMBRA_lights_area" not in b.doc["extensionsUsed"]:
            b.doc["extensionsUsed"].append("PENUMBRA_lights_area")
        b.node({"name": name, "translation": list(eye), "rotation": look_rotation(eye, target),
                "extensions": {"PENUMBRA_lights_area": ext}})

    area_node("softbox", {"shape": "rect", "luminance": 3.0, "width": 1.2, "height": 0.6, "color": [1.0, 0.95, 0.9]},
              (-1.5, 2.2, 1.2), (-0.3, 0.0, 0.0))
    area_node("disk", {"shape": "disk", "luminance": 4.0, "radius": 0.3, "color": [0.8, 0.9, 1.0]},
              (1.8, 1.6, 0.8), (0.5, 0.0, -0.2))
    area_node("bulb", {"shape": "sphere", "intensity": 1.5, "radius": 0.12, "color": [1.0, 0.8, 0.6]},
              (0.2, 1.3, 1.0), (0.2, 0.0, 1.0))
    b.camera((0, 1.6, 4.2), (0, 0.4, 0), 40)
    b.write(os.path.join(SCENES, "area.gltf"))


def helmet():
    """DamagedHelmet with a sun and two point lights, reading the committed .glb as its buffer
    (its binary chunk's offset added to every buffer view)."""
    folder = os.path.join(ROOT, "tests", "assets", "DamagedHelmet")
    glb = open(os.path.join(folder, "DamagedHelmet.glb"), "rb").read()
    json_len = struct.unpack("<I", glb[12:16])[0]
    doc = json.loads(glb[20 : 20 + json_len])
    bin_offset = 20 + json_len + 8
    for view in doc["bufferViews"]:
        view["byteOffset"] = view.get("byteOffset", 0) + bin_offset
    doc["buffers"] = [{"byteLength": len(glb), "uri": "DamagedHelmet.glb"}]
    lights = [
        {"type": "directional", "intensity": 2.0, "color": [1.0, 0.96, 0.9]},
        {"type": "point", "intensity": 3.0, "color": [1.0, 0.6, 0.35]},
        {"type": "point", "intensity": 2.0, "color": [0.4, 0.6, 1.0]},
    ]
    doc["extensions"] = {"KHR_lights_punctual": {"lights": lights}}
    doc["extensionsUsed"] = sorted(set(doc.get("extensionsUsed", []) + ["KHR_lights_punctual"]))
    roots = doc["scenes"][0]["nodes"]
    placed = [
        {"name": "sun", "rotation": look_rotation((0, 0, 0), (-0.5, -0.6, -0.8)), "extensions": {"KHR_lights_punctual": {"light": 0}}},
        {"name": "warm", "translation": [1.6, 0.8, 1.4], "extensions": {"KHR_lights_punctual": {"light": 1}}},
        {"name": "cool", "translation": [-1.7, -0.4, 1.2], "extensions": {"KHR_lights_punctual": {"light": 2}}},
    ]
    eye = (0.0, 0.0, 3.2)
    doc["cameras"] = [{"type": "perspective", "perspective": {"yfov": math.radians(40), "znear": 0.05, "aspectRatio": 1.0}}]
    placed.append({"name": "camera", "camera": 0, "translation": list(eye), "rotation": look_rotation(eye, (0, 0, 0))})
    for node in placed:
        doc["nodes"].append(node)
        roots.append(len(doc["nodes"]) - 1)
    doc["asset"]["generator"] = "penumbra tools/make_reference_scenes.py (from DamagedHelmet.glb)"
    path = os.path.join(folder, "DamagedHelmetLit.gltf")
    with open(path, "w") as f:
        json.dump(doc, f, indent=1)
    print(f"wrote {os.path.relpath(path, ROOT)}")


def extension_scene(name, materials, description):
    """Three spheres of one material extension at three settings, under the spheres scene's sun
    and point light, on black."""
    b = Builder()
    geom = b.geometry(*sphere_uv(0.42))
    for col, (label, color, metallic, rough, ext) in enumerate(materials):
        m = b.material(label, color, metallic, rough, ext)
        b.mesh_node(f"sphere_{label}", geom, m, (col - 1.0, 0.0, 0.0))
    b.light("sun", {"type": "directional", "intensity": 2.5}, (0, 0, 0), look_rotation((0, 0, 0), (-0.4, -0.5, -1.0)))
    b.light("point", {"type": "point", "intensity": 6.0, "color": [1.0, 0.9, 0.8]}, (2.5, 2.0, 2.5))
    b.camera((0, 0, 3.6), (0, 0, 0), 40)
    b.doc["asset"]["extras"] = {"description": description}
    b.write(os.path.join(SCENES, f"{name}.gltf"))


def extension_scenes():
    """One scene per material extension that Blender's glTF importer maps (coat, sheen,
    specular and IOR, anisotropy, thin film), and a glass pane in front of a two-coloured
    emitting wall for transmission."""
    red, blue, grey = (0.8, 0.1, 0.08), (0.05, 0.1, 0.35), (0.5, 0.5, 0.5)
    coat = lambda f, r: {"KHR_materials_clearcoat": {"clearcoatFactor": f, "clearcoatRoughnessFactor": r}}
    extension_scene("ext_coat", [("coat_full_smooth", red, 0.0, 0.6, coat(1.0, 0.05)),
                                 ("coat_half_rough", red, 0.0, 0.6, coat(0.5, 0.4)),
                                 ("coat_over_metal", (0.9, 0.6, 0.3), 1.0, 0.5, coat(1.0, 0.1))],
                    "KHR_materials_clearcoat")
    sheen = lambda c, r: {"KHR_materials_sheen": {"sheenColorFactor": c, "sheenRoughnessFactor": r}}
    extension_scene("ext_sheen", [("sheen_white_soft", blue, 0.0, 0.8, sheen([0.8, 0.8, 0.8], 0.3)),
                                  ("sheen_white_rough", blue, 0.0, 0.8, sheen([0.8, 0.8, 0.8], 0.8)),
                                  ("sheen_gold", (0.05, 0.05, 0.05), 0.0, 0.9, sheen([1.0, 0.7, 0.2], 0.5))],
                    "KHR_materials_sheen")
    spec = lambda ior, f, c: {"KHR_materials_ior": {"ior": ior},
                              "KHR_materials_specular": {"specularFactor": f, "specularColorFactor": c}}
    extension_scene("ext_specular", [("ior_1_2", grey, 0.0, 0.3, spec(1.2, 1.0, [1, 1, 1])),
                                     ("ior_2_0", grey, 0.0, 0.3, spec(2.0, 1.0, [1, 1, 1])),
                                     ("half_specular_tinted", grey, 0.0, 0.3, spec(1.5, 0.5, [1.0, 0.6, 0.3]))],
                    "KHR_materials_ior and KHR_materials_specular")
    aniso = lambda s, r: {"KHR_materials_anisotropy": {"anisotropyStrength": s, "anisotropyRotation": r}}
    extension_scene("ext_anisotropy", [("aniso_0_5", (0.9, 0.9, 0.9), 1.0, 0.3, aniso(0.5, 0.0)),
                                       ("aniso_1", (0.9, 0.9, 0.9), 1.0, 0.3, aniso(1.0, 0.0)),
                                       ("aniso_1_turned", (0.9, 0.9, 0.9), 1.0, 0.3, aniso(1.0, 1.5707963))],
                    "KHR_materials_anisotropy")
    film = lambda t: {"KHR_materials_iridescence": {"iridescenceFactor": 1.0, "iridescenceIor": 1.3,
                                                    "iridescenceThicknessMaximum": t}}
    extension_scene("ext_iridescence", [("film_250", (0.05, 0.05, 0.05), 0.0, 0.2, film(250)),
                                        ("film_400", (0.05, 0.05, 0.05), 0.0, 0.2, film(400)),
                                        ("film_over_metal", (0.6, 0.6, 0.6), 1.0, 0.2, film(550))],
                    "KHR_materials_iridescence")
    # Transmission: thin panes (no volume: thin-walled) in front of an emitting wall, half orange,
    # half blue. Each pane is a closed slab 1 cm thick, so that Cycles, which has no thin-walled
    # model, refracts into it and back out (a 1 cm offset at most) instead of into a half-space.
    b = Builder()
    wall = quad(1.6, 2.4, 1)
    for x, c in ((-0.8, [1.0, 0.5, 0.1]), (0.8, [0.1, 0.3, 1.0])):
        m = b.material(f"wall_{x}", (0, 0, 0), 0.0, 1.0, None, emissiveFactor=c)
        b.mesh_node(f"wall_{x}", b.geometry(*wall), m, (x, 0, -1.0), axis_angle((1, 0, 0), 90))
    pane = box(0.8, 0.01, 0.8)
    glass = lambda base, r: {"KHR_materials_transmission": {"transmissionFactor": 1.0}}
    for col, (base, rough) in enumerate([((1, 1, 1), 0.0), ((1.0, 0.8, 0.8), 0.0), ((0.8, 1.0, 0.8), 0.3)]):
        m = b.material(f"pane_{col}", base, 0.0, rough, glass(base, rough))
        b.mesh_node(f"pane_{col}", b.geometry(*pane), m, (col - 1.0, 0.0, 0.0), axis_angle((1, 0, 0), 90))
    # A dim light, so that neither renderer adds lights of its own to an unlit scene.
    b.light("point", {"type": "point", "intensity": 1.0}, (0.0, 3.0, 3.0))
    b.camera((0, 0, 3.6), (0, 0, 0), 40)
    b.doc["asset"]["extras"] = {"description": "KHR_materials_transmission"}
    b.write(os.path.join(SCENES, "ext_transmission.gltf"))


if __name__ == "__main__":
    extension_scenes()
    spheres()
    cornell()
    sun_csm()
    area()
    helmet()
