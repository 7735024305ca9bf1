#!/usr/bin/env python3
"""The glTF sample models' extensions against Penumbra's supported list, before and after.

Usage: tools/extension_coverage.py SAMPLES_GIT_DIR BEFORE_COMMIT [AFTER_COMMIT]

SAMPLES_GIT_DIR is a git directory of the glTF sample assets (a bare clone or `fetch` mirror:
`Models/<name>/<variant>/...`). Each model is read from its `glTF` variant, else `glTF-Binary`,
else `glTF-Embedded` (the JSON only; no buffer is needed). The supported list is
SUPPORTED_EXTENSIONS in crates/engine/src/import/gltf/mod.rs at each commit of this repository.
A model is *rendered* when every extension it uses is supported, *refused* when one it requires is
not, and *ignored* otherwise (an optional extension left out, with a warning). Prints a Markdown
table (model, extensions not supported before, status before, status after) and a summary.
"""
import json
import re
import struct
import subprocess
import sys


def git(gitdir, *args):
    return subprocess.run(["git", "--git-dir", gitdir, *args], capture_output=True, check=True).stdout


def supported(commit):
    src = subprocess.run(
        ["git", "show", f"{commit}:crates/engine/src/import/gltf/mod.rs"], capture_output=True, check=True, text=True
    ).stdout
    block = src[src.index("SUPPORTED_EXTENSIONS") :]
    block = block[: block.index("];")]
    return set(re.findall(r'"([A-Za-z0-9_]+)"', block))


def model_json(gitdir, model, files):
    for variant, ext in (("glTF", ".gltf"), ("glTF-Binary", ".glb"), ("glTF-Embedded", ".gltf")):
        for f in files:
            if f.startswith(f"Models/{model}/{variant}/") and f.endswith(ext):
                try:
                    data = git(gitdir, "show", f"HEAD:{f}")
                except subprocess.CalledProcessError:
                    continue
                if ext == ".glb":
                    if len(data) < 20:
                        continue
                    n = struct.unpack_from("<I", data, 12)[0]
                    data = data[20 : 20 + n]
                try:
                    return json.loads(data)
                except ValueError:
                    continue
    return None


def status(doc, ok):
    used = set(doc.get("extensionsUsed", []))
    required = set(doc.get("extensionsRequired", []))
    if required - ok:
        return "refused"
    if used - ok:
        return "ignored"
    return "rendered"


def main():
    gitdir, before_commit = sys.argv[1], sys.argv[2]
    after_commit = sys.argv[3] if len(sys.argv) > 3 else "HEAD"
    before, after = supported(before_commit), supported(after_commit)
    files = git(gitdir, "ls-tree", "-r", "--name-only", "HEAD", "Models").decode().split("\n")
    models = sorted({f.split("/")[1] for f in files if f.count("/") >= 2})
    rows, counts = [], {}
    for model in models:
        doc = model_json(gitdir, model, files)
        if doc is None:
            continue
        b, a = status(doc, before), status(doc, after)
        counts[(b, a)] = counts.get((b, a), 0) + 1
        missing = sorted(set(doc.get("extensionsUsed", [])) - before)
        if missing:
            still = sorted(set(doc.get("extensionsUsed", [])) - after)
            rows.append((model, missing, b, a, still))
    print("| model | extensions not supported before | before | after | still not supported |")
    print("|---|---|---|---|---|")
    for model, missing, b, a, still in rows:
        print(f"| {model} | {', '.join(missing)} | {b} | {a} | {', '.join(still) or '—'} |")
    total = sum(counts.values())
    print()
    for kind in ("rendered", "ignored", "refused"):
        nb = sum(v for (b, _), v in counts.items() if b == kind)
        na = sum(v for (_, a), v in counts.items() if a == kind)
        print(f"{kind}: {nb} before, {na} after (of {total} models read)")


if __name__ == "__main__":
    main()
