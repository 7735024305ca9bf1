#!/bin/sh
# Renders every reference of tests/reference with Blender's Cycles (tools/reference.py): direct
# light only (the fair comparison for a rasteriser) and full global illumination, 256x256.
# Needs the bpy wheel: python3 -m venv /opt/bpyenv && /opt/bpyenv/bin/pip install bpy==4.2.0
# Usage: tools/make_references.sh [PYTHON] (default /opt/bpyenv/bin/python)
set -eu
py=${1:-/opt/bpyenv/bin/python}
cd "$(dirname "$0")/.."
python3 tools/make_reference_scenes.py
while read -r name path; do
    case "$name" in ''|'#'*) continue ;; esac
    scene=tests/reference/$path
    "$py" tools/reference.py "$scene" --out "tests/reference/refs/$name.direct" --spp 256 --bounces 0 | tail -n 1
    "$py" tools/reference.py "$scene" --out "tests/reference/refs/$name.gi" --spp 512 --bounces 8 | tail -n 1
done < tests/reference/suite.txt
