#!/usr/bin/env python3
"""Writes scenes/textured-room/: a room with a checkerboard floor (map_Kd), a painted back
wall (map_Kd) and a striped light panel (map_Ke). Standard library only."""
import os, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scene_png import scene_folder, write_png  # noqa: E402

here = scene_folder("textured-room")

write_png(here, "checker.png", 64, 64, lambda x, y: (235, 230, 220) if (x // 16 + y // 16) % 2 == 0 else (40, 45, 60))
write_png(here, "painting.png", 64, 64, lambda x, y: (200, 60 + 2 * y, 40) if ((x - 32) ** 2 + (y - 32) ** 2) < 400 else (40, 90, 160 + y))
write_png(here, "panel.png", 32, 32, lambda x, y: (255, 190, 120) if (x // 8) % 2 == 0 else (120, 170, 255))

quads = [  # material, corners (counter-clockwise from the front), uv scale
    ("floor", [(-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1)], 3),
    ("ceiling", [(-1, 2, -1), (1, 2, -1), (1, 2, 1), (-1, 2, 1)], 1),
    ("back", [(-1, 0, -1), (1, 0, -1), (1, 2, -1), (-1, 2, -1)], 1),
    ("left", [(-1, 0, 1), (-1, 0, -1), (-1, 2, -1), (-1, 2, 1)], 1),
    ("right", [(1, 0, -1), (1, 0, 1), (1, 2, 1), (1, 2, -1)], 1),
    ("panel", [(-0.5, 1.98, -0.5), (0.5, 1.98, -0.5), (0.5, 1.98, 0.5), (-0.5, 1.98, 0.5)], 1),
]
obj = ["# A room with textured surfaces and a textured emitter (written by tools/make-textured-room.py)", "mtllib room.mtl"]
for n, (mat, corners, s) in enumerate(quads):
    obj += [f"v {x} {y} {z}" for x, y, z in corners]
    obj += [f"vt {u * s} {v * s}" for u, v in [(0, 0), (1, 0), (1, 1), (0, 1)]]
    b = 4 * n + 1
    obj += [f"usemtl {mat}", "f " + " ".join(f"{b + k}/{b + k}" for k in range(4))]
open(os.path.join(here, "room.obj"), "w").write("\n".join(obj) + "\n")
open(os.path.join(here, "room.mtl"), "w").write("""newmtl floor
Kd 0.9 0.9 0.9
map_Kd checker.png

newmtl back
Kd 0.8 0.8 0.8
map_Kd painting.png

newmtl ceiling
Kd 0.75 0.75 0.75

newmtl left
Kd 0.7 0.7 0.7

newmtl right
Kd 0.7 0.7 0.7

newmtl panel
Kd 0.0 0.0 0.0
Ke 6 6 6
map_Ke panel.png
""")
open(os.path.join(here, "scene.toml"), "w").write("""# Textured surfaces (map_Kd on the floor and back wall) and a textured emitter (map_Ke on the
# light panel). Written by tools/make-textured-room.py.
name = "textured-room"
mesh = "room.obj"

[[camera]]
name = "front"
eye = [0.0, 1.0, 3.6]
target = [0.0, 0.9, 0.0]
up = [0.0, 1.0, 0.0]
fov_y_deg = 42.0
size = [512, 512]

[[camera]]
name = "up"
eye = [0.0, 0.6, 0.9]
target = [0.0, 2.0, -0.2]
up = [0.0, 1.0, 0.0]
fov_y_deg = 70.0
size = [512, 512]
""")
