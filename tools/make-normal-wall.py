#!/usr/bin/env python3
"""Writes scenes/normal-wall/: a normal-mapped wall under grazing light (issue 29, normal maps).
A grey wall (x-y plane, facing +z) whose normal map (MTL `norm`) carries a grid of round bumps,
standing on a grey floor, lit by a small emitter far to its left at grazing incidence (about
75 degrees from the wall's normal at its middle): the bumps' lit and shaded sides show only
through the normal map. tools/normalmap-accuracy.py compares vlf's view of it with Mitsuba 3's
(`normalmap` BSDF). Standard library only."""
import math, os, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scene_png import scene_folder, write_png  # noqa: E402

here = scene_folder("normal-wall")


# 4 x 4 round bumps per tile (a spherical cap of slope up to 40 degrees), flat between them;
# x right and y up the image, as glTF and vlf take a normal map
N, CELLS = 128, 4


def bump_normal(x, y):
    cell = N / CELLS
    cx = (x + 0.5) % cell / cell * 2 - 1
    cy = -((y + 0.5) % cell / cell * 2 - 1)  # rows run down; y up
    r2 = cx * cx + cy * cy
    if r2 >= 0.64:
        return (0.0, 0.0, 1.0)
    # a cap of radius 0.8 (in cell halves), its slope growing to 40 degrees at the rim
    s = math.sin(math.radians(40)) * math.sqrt(r2) / 0.8
    r = math.sqrt(r2)
    nx, ny = s * cx / r if r > 0 else 0.0, s * cy / r if r > 0 else 0.0
    return (nx, ny, math.sqrt(max(1 - nx * nx - ny * ny, 0.0)))


write_png(here, "bumps.png", N, N, lambda x, y: tuple(round(255 * (0.5 + 0.5 * c)) for c in bump_normal(x, y)))

quads = [  # material, corners (counter-clockwise from the front), texture coordinates
    ("wall", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [(0, 0), (2, 0), (2, 2), (0, 2)]),
    ("floor", [(-1, -1, 2), (1, -1, 2), (1, -1, 0), (-1, -1, 0)], [(0, 0), (1, 0), (1, 1), (0, 1)]),
]
# the emitter: 0.2 x 0.2, at (-3.5, 0.3, 0.95), facing the wall's middle
c = (-3.5, 0.3, 0.95)
length = math.sqrt(sum(v * v for v in c))
n = tuple(-v / length for v in c)
a = (0.0, 1.0, 0.0)
b = (n[1] * a[2] - n[2] * a[1], n[2] * a[0] - n[0] * a[2], n[0] * a[1] - n[1] * a[0])
blen = math.sqrt(sum(v * v for v in b))
b = tuple(v / blen for v in b)
h = 0.1
light = [tuple(c[k] + sa * h * a[k] + sb * h * b[k] for k in range(3)) for sa, sb in [(-1, -1), (-1, 1), (1, 1), (1, -1)]]
e1 = [light[1][k] - light[0][k] for k in range(3)]
e2 = [light[2][k] - light[0][k] for k in range(3)]
front = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
if sum(front[k] * n[k] for k in range(3)) < 0:
    light.reverse()
obj = ["# A normal-mapped wall on a floor under grazing light (tools/make-normal-wall.py)", "mtllib normal-wall.mtl"]
vt = 1
for k, (mat, corners, uv) in enumerate(quads):
    obj += [f"v {x!r} {y!r} {z!r}" for x, y, z in corners]
    obj += [f"vt {u} {v}" for u, v in uv]
    obj += [f"usemtl {mat}", "f " + " ".join(f"{4 * k + i + 1}/{4 * k + i + 1}" for i in range(4))]
obj += [f"v {x!r} {y!r} {z!r}" for x, y, z in light]
obj += ["usemtl light", "f " + " ".join(str(9 + i) for i in range(4))]
open(os.path.join(here, "normal-wall.obj"), "w").write("\n".join(obj) + "\n")
open(os.path.join(here, "normal-wall.mtl"), "w").write("""newmtl wall
Kd 0.7 0.7 0.7
norm bumps.png

newmtl floor
Kd 0.4 0.4 0.4

newmtl light
Kd 0 0 0
Ke 1000 1000 1000
""")
open(os.path.join(here, "scene.toml"), "w").write("""# A wall whose normal map (MTL norm) carries round bumps, on a floor, under grazing light.
# Written by tools/make-normal-wall.py; tools/normalmap-accuracy.py compares it with Mitsuba 3.
name = "normal-wall"
mesh = "normal-wall.obj"

[[camera]]
name = "front"
eye = [0.0, 0.0, 3.2]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov_y_deg = 40.0
size = [512, 512]
""")
