#!/usr/bin/env python3
"""Writes the small glTF scenes under tests/assets/Defaults/ that reproduce what the default
camera and exposure must handle (tests/defaults.rs renders them with no settings):

- SunLit.gltf: a ground, a box and a pillar lit by a 6,830 lux sun (KHR_lights_punctual
  directional, as Blender's exporter writes a 10 W/m² sun).
- DimLamp.gltf: the same objects lit by one 12 cd point light (about 5 lux on them).
- FlatPlane.gltf: one two-coloured quad lying in the XZ plane, no lights.
- Sweep.gltf: a box that an animation moves 6 m along +X over 2 s, starting at the origin.

Run from the repository root: python3 tools/default_scenes.py
"""
import base64
import json
import math
import struct

OUT = "tests/assets/Defaults/"


def box(cx, cy, cz, sx, sy, sz):
    """Positions, normals and indices of an axis-aligned box (centre, half sizes)."""
    pos, nrm, idx = [], [], []
    faces = [
        ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
        ((-1, 0, 0), (0, 1, 0), (0, 0, -1)),
        ((0, 1, 0), (0, 0, 1), (1, 0, 0)),
        ((0, -1, 0), (0, 0, -1), (1, 0, 0)),
        ((0, 0, 1), (1, 0, 0), (0, 1, 0)),
        ((0, 0, -1), (-1, 0, 0), (0, 1, 0)),
    ]
    for n, u, v in faces:
        base = len(pos)
        for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            p = [n[i] + a * u[i] + b * v[i] for i in range(3)]
            pos.append((cx + p[0] * sx, cy + p[1] * sy, cz + p[2] * sz))
            nrm.append(n)
        # Counter-clockwise seen from outside: u x v = n for every face above.
        idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    return pos, nrm, idx


def quad_xz(half):
    pos = [(-half, 0, half), (half, 0, half), (half, 0, -half), (-half, 0, -half)]
    return pos, [(0, 1, 0)] * 4, [0, 1, 2, 0, 2, 3]


class Doc:
    def __init__(self):
        self.bin = bytearray()
        self.g = {"asset": {"version": "2.0", "generator": "penumbra tools/default_scenes.py"},
                  "scene": 0, "scenes": [{"nodes": []}], "nodes": [], "meshes": [], "materials": [],
                  "accessors": [], "bufferViews": [], "buffers": []}

    def view(self, data, target=None):
        while len(self.bin) % 4:
            self.bin.append(0)
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target:
            v["target"] = target
        self.bin += data
        self.g["bufferViews"].append(v)
        return len(self.g["bufferViews"]) - 1

    def accessor(self, values, kind, comp=5126, target=None, minmax=False):
        width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[kind]
        flat = [c for v in values for c in (v if width > 1 else (v,))]
        fmt = {5126: "f", 5125: "I"}[comp]
        a = {"bufferView": self.view(struct.pack("<%d%s" % (len(flat), fmt), *flat), target),
             "componentType": comp, "count": len(values), "type": kind}
        if minmax:
            a["min"] = [min(v[i] for v in values) for i in range(width)] if width > 1 else [min(values)]
            a["max"] = [max(v[i] for v in values) for i in range(width)] if width > 1 else [max(values)]
        self.g["accessors"].append(a)
        return len(self.g["accessors"]) - 1

    def material(self, name, color, roughness=0.6, double=False):
        m = {"name": name, "pbrMetallicRoughness": {"baseColorFactor": list(color) + [1.0],
                                                     "metallicFactor": 0.0, "roughnessFactor": roughness}}
        if double:
            m["doubleSided"] = True
        self.g["materials"].append(m)
        return len(self.g["materials"]) - 1

    def mesh(self, name, parts):
        prims = []
        for (pos, nrm, idx), mat in parts:
            prims.append({"attributes": {"POSITION": self.accessor(pos, "VEC3", target=34962, minmax=True),
                                         "NORMAL": self.accessor(nrm, "VEC3", target=34962)},
                          "indices": self.accessor(idx, "SCALAR", comp=5125, target=34963), "material": mat})
        self.g["meshes"].append({"name": name, "primitives": prims})
        return len(self.g["meshes"]) - 1

    def node(self, node, root=True):
        self.g["nodes"].append(node)
        i = len(self.g["nodes"]) - 1
        if root:
            self.g["scenes"][0]["nodes"].append(i)
        return i

    def save(self, name):
        self.g["buffers"] = [{"byteLength": len(self.bin),
                              "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(self.bin)).decode()}]
        with open(OUT + name, "w") as f:
            json.dump(self.g, f, indent=1)
            f.write("\n")


def still_life(doc):
    ground = doc.material("ground", (0.5, 0.5, 0.5))
    red = doc.material("red", (0.8, 0.1, 0.08), 0.4)
    white = doc.material("white", (0.8, 0.8, 0.8), 0.5)
    doc.node({"name": "ground", "mesh": doc.mesh("ground", [(quad_xz(4.0), ground)])})
    doc.node({"name": "box", "mesh": doc.mesh("box", [(box(-0.8, 0.5, 0.3, 0.5, 0.5, 0.5), red)])})
    doc.node({"name": "pillar", "mesh": doc.mesh("pillar", [(box(0.9, 1.0, -0.4, 0.3, 1.0, 0.3), white)])})


def quat_towards(d):
    """The rotation taking local −Z to unit direction d (lights shine down −Z)."""
    dx, dy, dz = d
    # Axis −Z × d, angle acos(−Z · d).
    ax, ay, az = dy, -dx, 0.0
    s = math.sqrt(ax * ax + ay * ay + az * az)
    angle = math.acos(max(-1.0, min(1.0, -dz)))
    if s < 1e-9:
        return [0, 0, 0, 1]
    h = angle / 2
    return [ax / s * math.sin(h), ay / s * math.sin(h), az / s * math.sin(h), math.cos(h)]


def sun_lit():
    doc = Doc()
    still_life(doc)
    doc.g["extensionsUsed"] = ["KHR_lights_punctual"]
    doc.g["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"name": "Sun", "type": "directional", "intensity": 6830.0, "color": [1.0, 0.96, 0.9]}]}}
    d = (-0.4, -0.8, -0.45)
    n = math.sqrt(sum(c * c for c in d))
    doc.node({"name": "Sun", "rotation": quat_towards(tuple(c / n for c in d)),
              "extensions": {"KHR_lights_punctual": {"light": 0}}})
    doc.save("SunLit.gltf")


def dim_lamp():
    doc = Doc()
    still_life(doc)
    doc.g["extensionsUsed"] = ["KHR_lights_punctual"]
    doc.g["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"name": "Lamp", "type": "point", "intensity": 12.0, "color": [1.0, 0.85, 0.7]}]}}
    doc.node({"name": "Lamp", "translation": [0.5, 1.4, 1.2], "extensions": {"KHR_lights_punctual": {"light": 0}}})
    doc.save("DimLamp.gltf")


def flat_plane():
    doc = Doc()
    a = doc.material("light", (0.8, 0.75, 0.6), double=True)
    b = doc.material("dark", (0.1, 0.3, 0.6), double=True)
    left = ([(-1, 0, 1), (0, 0, 1), (0, 0, -1), (-1, 0, -1)], [(0, 1, 0)] * 4, [0, 1, 2, 0, 2, 3])
    right = ([(0, 0, 1), (1, 0, 1), (1, 0, -1), (0, 0, -1)], [(0, 1, 0)] * 4, [0, 1, 2, 0, 2, 3])
    doc.node({"name": "plane", "mesh": doc.mesh("plane", [(left, a), (right, b)])})
    doc.save("FlatPlane.gltf")


def sweep():
    doc = Doc()
    red = doc.material("red", (0.8, 0.1, 0.08), 0.4)
    doc.node({"name": "box", "mesh": doc.mesh("box", [(box(0, 0.5, 0, 0.5, 0.5, 0.5), red)])})
    times = doc.accessor([0.0, 2.0], "SCALAR", minmax=True)
    moves = doc.accessor([(0.0, 0.0, 0.0), (6.0, 0.0, 0.0)], "VEC3")
    doc.g["animations"] = [{"name": "sweep", "samplers": [{"input": times, "output": moves}],
                            "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}]}]
    doc.save("Sweep.gltf")


if __name__ == "__main__":
    sun_lit()
    dim_lamp()
    flat_plane()
    sweep()
