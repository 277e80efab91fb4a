#!/usr/bin/env python3
"""Writes scenes/fence/: a cut-out scene (issue 29, alpha cut-outs). A floor under a small
emitter, and between them a two-sided slatted panel whose slats are cut from a quad by an alpha
texture (MTL `map_d`, coverage 0.5 in eight stripes): the panel casts a striped shadow on the
floor. tools/fence-accuracy.py compares vlf's view of it with Mitsuba 3's. Standard library only."""
import os, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scene_png import scene_folder, write_png  # noqa: E402

here = scene_folder("fence")


# eight slats across u: 2 texels covered, 2 open (coverage 0.5, alpha 0 or 255 only)
write_png(here, "slats.png", 32, 4, lambda x, y: (255, 255, 255, 255 if (x // 2) % 2 == 0 else 0), alpha=True)

quads = [  # material, corners (counter-clockwise from the front)
    ("floor", [(-1.5, 0, 1.5), (1.5, 0, 1.5), (1.5, 0, -1.5), (-1.5, 0, -1.5)]),
    ("slats", [(-0.6, 0.6, 0.6), (0.6, 0.6, 0.6), (0.6, 0.6, -0.6), (-0.6, 0.6, -0.6)]),
    ("light", [(-0.15, 1.6, -0.15), (0.15, 1.6, -0.15), (0.15, 1.6, 0.15), (-0.15, 1.6, 0.15)]),
]
obj = ["# A slatted panel cut by map_d over a floor, under a small emitter (tools/make-fence.py)", "mtllib fence.mtl"]
for n, (mat, corners) in enumerate(quads):
    obj += [f"v {x} {y} {z}" for x, y, z in corners]
    obj += [f"vt {u} {v}" for u, v in [(0, 0), (1, 0), (1, 1), (0, 1)]]
    b = 4 * n + 1
    obj += [f"usemtl {mat}", "f " + " ".join(f"{b + k}/{b + k}" for k in range(4))]
open(os.path.join(here, "fence.obj"), "w").write("\n".join(obj) + "\n")
open(os.path.join(here, "fence.mtl"), "w").write("""newmtl floor
Kd 0.6 0.6 0.6

newmtl slats
Kd 0.7 0.55 0.35
map_d slats.png

newmtl light
Kd 0 0 0
Ke 20 20 20
""")
open(os.path.join(here, "scene.toml"), "w").write("""# A slatted panel cut from a quad by an alpha texture (map_d) casts a striped shadow on a floor.
# Written by tools/make-fence.py; tools/fence-accuracy.py compares it with Mitsuba 3.
name = "fence"
mesh = "fence.obj"

[materials.slats]
two_sided = true

[[camera]]
name = "front"
eye = [0.0, 1.9, 2.6]
target = [0.0, 0.2, 0.0]
up = [0.0, 1.0, 0.0]
fov_y_deg = 45.0
size = [512, 512]
""")
