#!/usr/bin/env python3
"""Writes a large plain glTF (GLB) for import benchmarks: a sphere of N x N quads displaced by a
few octaves of smooth waves, with normals, UVs and 32-bit indices (docs/performance.md compares
its import against compressed versions of it).

    python3 tools/large_mesh.py OUT.glb [N]     # N = 1000: 1.0 M vertices, 2.0 M triangles, 56 MB
"""
import json
import struct
import sys

import numpy as np


def main():
    out = sys.argv[1]
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 1000
    u = np.linspace(0.0, 1.0, n + 1, dtype=np.float64)
    uu, vv = np.meshgrid(u, u, indexing="xy")
    theta, phi = uu * 2 * np.pi, vv * np.pi
    d = np.stack([np.sin(phi) * np.cos(theta), np.cos(phi), np.sin(phi) * np.sin(theta)], axis=-1)
    r = 1.0 + 0.05 * np.sin(7 * theta) * np.sin(5 * phi) + 0.02 * np.sin(23 * theta + 3) * np.sin(19 * phi)
    p = d * r[..., None]
    # Normals from the surface's partial derivatives (central differences on the grid).
    dt = np.gradient(p, axis=1)
    dp = np.gradient(p, axis=0)
    nrm = np.cross(dp, dt)
    length = np.linalg.norm(nrm, axis=-1, keepdims=True)
    nrm = np.where(length > 1e-12, nrm / np.maximum(length, 1e-12), d)
    pos = p.reshape(-1, 3).astype(np.float32)
    nor = nrm.reshape(-1, 3).astype(np.float32)
    uv = np.stack([uu, vv], axis=-1).reshape(-1, 2).astype(np.float32)
    i = np.arange(n)
    a = (i[None, :] + i[:, None] * (n + 1)).reshape(-1)
    b, c, e = a + 1, a + n + 1, a + n + 2
    idx = np.stack([a, c, b, b, c, e], axis=-1).reshape(-1).astype(np.uint32)

    blobs = [pos.tobytes(), nor.tobytes(), uv.tobytes(), idx.tobytes()]
    views, offset = [], 0
    for k, blob in enumerate(blobs):
        view = {"buffer": 0, "byteOffset": offset, "byteLength": len(blob)}
        view["target"] = 34963 if k == 3 else 34962
        views.append(view)
        offset += len(blob)
    count = len(pos)
    doc = {
        "asset": {"version": "2.0", "generator": "penumbra tools/large_mesh.py"},
        "buffers": [{"byteLength": offset}],
        "bufferViews": views,
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": count, "type": "VEC3",
             "min": pos.min(axis=0).tolist(), "max": pos.max(axis=0).tolist()},
            {"bufferView": 1, "componentType": 5126, "count": count, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": count, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5125, "count": len(idx), "type": "SCALAR"},
        ],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.5, 0.3, 1], "metallicFactor": 0.0,
                                                "roughnessFactor": 0.5}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                                    "indices": 3, "material": 0}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    }
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    bin_ = b"".join(blobs)
    bin_ += b"\0" * (-len(bin_) % 4)
    total = 12 + 8 + len(js) + 8 + len(bin_)
    with open(out, "wb") as f:
        f.write(b"glTF" + struct.pack("<II", 2, total))
        f.write(struct.pack("<I", len(js)) + b"JSON" + js)
        f.write(struct.pack("<I", len(bin_)) + b"BIN\0" + bin_)
    print(f"{out}: {count} vertices, {len(idx) // 3} triangles, {total} bytes")


main()
