#!/usr/bin/env python3
"""Writes tests/assets/SunAndPoint/SunAndPoint.gltf: a 10 m ground, a box and a sphere under a
shadowing sun and one shadowed point light, seen from 7 m. The small everyday scene behind the
screenshot memory and time figures in docs/shadows.md (a 512² `penumbra render` of it):

    python3 tools/small_shadow_scene.py
"""

import os

from make_reference_scenes import ROOT, Builder, box, look_rotation, quad, sphere


def main():
    b = Builder()
    ground = b.material("ground", (0.6, 0.6, 0.55), 0.0, 0.9)
    b.mesh_node("ground", b.geometry(*quad(10.0, 10.0)), ground, (0, 0, 0))
    red = b.material("box", (0.8, 0.2, 0.15), 0.0, 0.5)
    b.mesh_node("box", b.geometry(*box(1, 1, 1)), red, (-0.6, 0.5, 0), None)
    blue = b.material("sphere", (0.2, 0.45, 0.8), 0.0, 0.3)
    b.mesh_node("sphere", b.geometry(*sphere(0.5, 32, 16)), blue, (1.0, 0.5, 0.6))
    b.light("sun", {"type": "directional", "intensity": 3.0}, (0, 0, 0), look_rotation((0, 0, 0), (-0.4, -1.0, -0.6)))
    b.light("lamp", {"type": "point", "intensity": 8.0, "color": [1.0, 0.85, 0.7]}, (-1.5, 2.0, 1.5))
    b.camera((0, 3, 7), (0, 0.4, 0), 45)
    b.write(os.path.join(ROOT, "tests", "assets", "SunAndPoint", "SunAndPoint.gltf"))


if __name__ == "__main__":
    main()
