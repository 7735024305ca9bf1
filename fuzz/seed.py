#!/usr/bin/env python3
"""Seeds fuzz/corpus/<target>/ from the repository's test assets (run from anywhere).

glTF files with external buffers and images get them inlined as data URIs, because the fuzz
targets resolve files against a folder that does not exist; large files are skipped (libFuzzer
mutates small inputs far faster). Shader seeds are every embedded shader, prefixed by the byte
that makes the target pick that file.
"""
import base64
import json
import pathlib
import re
import struct

ROOT = pathlib.Path(__file__).resolve().parent.parent
CORPUS = ROOT / "fuzz" / "corpus"
MAX_SEED = 300_000


def put(target, name, data):
    d = CORPUS / target
    d.mkdir(parents=True, exist_ok=True)
    if len(data) <= MAX_SEED:
        (d / name).write_bytes(data)


def inline_gltf(path):
    doc = json.loads(path.read_text())
    for key in ("buffers", "images"):
        for item in doc.get(key, []):
            uri = item.get("uri")
            if uri and not uri.startswith("data:"):
                f = path.parent / uri.replace("%20", " ")
                if not f.exists() or f.stat().st_size > MAX_SEED:
                    return None
                mime = "application/octet-stream" if key == "buffers" else "image/png"
                item["uri"] = f"data:{mime};base64," + base64.b64encode(f.read_bytes()).decode()
    return json.dumps(doc, separators=(",", ":")).encode()


def glb_parts(data):
    """A GLB's JSON and binary chunk."""
    n = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + n])
    m = struct.unpack_from("<I", data, 20 + n)[0]
    return doc, data[28 + n:28 + n + m]


def seed_compressed():
    """The compressed target's seeds: every Draco stream and meshopt bufferView of the test
    assets, with the prefix that makes the target wrap it as the file did."""
    assets = ROOT / "tests" / "assets"
    for path in sorted(assets.rglob("*.gltf")) + sorted(assets.rglob("*.glb")):
        if path.suffix == ".glb":
            doc, blob = glb_parts(path.read_bytes())
            buffers = [blob]
        else:
            doc = json.loads(path.read_text())
            buffers = []
            for b in doc.get("buffers", []):
                uri = b.get("uri", "")
                f = path.parent / uri
                buffers.append(f.read_bytes() if uri and not uri.startswith("data:") and f.is_file() else b"")
        views = doc.get("bufferViews", [])

        def view_bytes(v, ext=None):
            src = ext or v
            data = buffers[src["buffer"]] if src["buffer"] < len(buffers) else b""
            at = src.get("byteOffset", 0)
            return data[at:at + src["byteLength"]]

        for m, mesh in enumerate(doc.get("meshes", [])):
            for p, prim in enumerate(mesh["primitives"]):
                d = prim.get("extensions", {}).get("KHR_draco_mesh_compression")
                if d:
                    ids = [d["attributes"].get(k, 0) for k in ("POSITION", "NORMAL", "TEXCOORD_0")]
                    put("compressed", f"{path.stem}-draco-{m}-{p}", bytes([0] + ids) + view_bytes(views[d["bufferView"]]))
        for i, v in enumerate(views):
            for name in ("EXT_meshopt_compression", "KHR_meshopt_compression"):
                e = v.get("extensions", {}).get(name)
                if e:
                    mode = ["ATTRIBUTES", "TRIANGLES", "INDICES"].index(e["mode"])
                    filt = ["NONE", "OCTAHEDRAL", "QUATERNION", "EXPONENTIAL", "COLOR"].index(e.get("filter", "NONE"))
                    pick = 1 | mode << 1 | filt << 3
                    head = bytes([pick, e["byteStride"]]) + struct.pack("<H", min(e["count"], 65535))
                    put("compressed", f"{path.stem}-meshopt-{i}", head + view_bytes(v, e))


def main():
    assets = [ROOT / "tests" / "assets", ROOT / "tests" / "reference" / "scenes"]
    for base in assets:
        for p in sorted(base.rglob("*")):
            safe = re.sub(r"[^A-Za-z0-9_.-]", "_", p.name)
            if p.suffix == ".glb":
                put("gltf", safe, p.read_bytes())
            elif p.suffix == ".gltf":
                data = inline_gltf(p)
                if data:
                    put("gltf", safe, data)
            elif p.suffix == ".obj":
                put("obj", safe, p.read_bytes())
            elif p.suffix in (".png", ".jpg", ".jpeg", ".webp", ".ktx2"):
                put("image", safe, b"\x00" + p.read_bytes())
            elif p.suffix in (".hdr", ".exr"):
                put("image", safe, b"\x01" + p.read_bytes())
    # IES: the shapes the parser meets in practice (LM-63-1995/2002, TILT=NONE, symmetric and
    # full horizontal ranges).
    put("ies", "point.ies", b"IESNA:LM-63-2002\n[TEST] seed\nTILT=NONE\n1 -1 1 3 1 1 2 0 0 0\n1 1 0\n0 45 90\n0\n100 80 10\n")
    put("ies", "quad.ies", b"IESNA:LM-63-1995\n[MANUFAC] seed\nTILT=NONE\n1 1000 1 2 3 1 1 0.5 0.5 0\n1 1 50\n0 90\n0 90 180\n"
        b"10 5\n10 6\n10 7\n")
    seed_compressed()
    shaders = sorted((ROOT / "shaders").glob("*.wgsl"))
    embedded = re.findall(r'\("([a-z_]+\.wgsl)"', (ROOT / "crates/render/src/pipelines/shader_library.rs").read_text())
    for s in shaders:
        if s.name in embedded:
            put("shader", s.name, bytes([embedded.index(s.name)]) + s.read_bytes())
    for t in sorted(CORPUS.iterdir()):
        print(t.name, len(list(t.iterdir())))


main()
