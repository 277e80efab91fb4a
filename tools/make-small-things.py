#!/usr/bin/env python3
"""Writes scenes/small-things/: a study room whose detail is smaller than vlf's texels and grid
cells at default settings (issue "small geometry keeps its own shading"). The room is 4 x 2.8 x 5 m,
so after normalisation to the unit sphere one texel (density 96) is about 3.6 cm and one grid cell
(256 per side) about 2.7 cm. On and around a table stand coloured cubes of 5 mm to 8 cm, pencils
7 mm thick, a 24-sided mug, a door with a 2 cm lever handle, a chair with 3 cm legs and a red
cushion, and a shelf of 60 books 2-4 cm thick. Every small thing has a colour of its own, unlike
what it stands on, so shading borrowed from a neighbour shows as a wrong colour. Lit by the sky
through a window and by a ceiling panel. One-sided faces, outward normals (room: inward).

    python3 tools/make-small-things.py [OUT_DIR=scenes/small-things]

Standard library only; deterministic (a seeded random.Random for the books).
"""
import math
import os
import random
import sys

OUT = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "scenes", "small-things")

MATERIALS = {  # name: (Kd, Ke)
    "wall": ((0.75, 0.74, 0.70), None),
    "floor": ((0.45, 0.35, 0.25), None),
    "ceiling": ((0.80, 0.80, 0.80), None),
    "lamp": ((0.0, 0.0, 0.0), (12.0, 11.0, 9.5)),
    "table": ((0.55, 0.55, 0.55), None),
    "door": ((0.50, 0.32, 0.18), None),
    "brass": ((0.85, 0.70, 0.20), None),
    "red": ((0.80, 0.08, 0.06), None),
    "green": ((0.10, 0.65, 0.15), None),
    "blue": ((0.08, 0.15, 0.75), None),
    "yellow": ((0.85, 0.80, 0.10), None),
    "white": ((0.90, 0.90, 0.90), None),
    "black": ((0.04, 0.04, 0.04), None),
}
BOOK_COLOURS = ["red", "green", "blue", "yellow", "white", "black"]


class Mesh:
    def __init__(self):
        self.v, self.groups = [], {}

    def poly(self, mat, corners):
        """A polygon, corners counter-clockwise seen from its front."""
        base = len(self.v) + 1
        self.v += corners
        self.groups.setdefault(mat, []).append([base + k for k in range(len(corners))])

    def quad(self, mat, o, a, b):
        """The parallelogram o, o+a, o+a+b, o+b (front: a x b)."""
        add = lambda p, q: tuple(x + y for x, y in zip(p, q))
        self.poly(mat, [o, add(o, a), add(add(o, a), b), add(o, b)])

    def box(self, mat, lo, hi):
        """An axis-aligned cuboid, outward normals."""
        (x0, y0, z0), (x1, y1, z1) = lo, hi
        dx, dy, dz = (x1 - x0, 0, 0), (0, y1 - y0, 0), (0, 0, z1 - z0)
        self.quad(mat, (x0, y0, z0), dz, dy)            # -x
        self.quad(mat, (x1, y0, z0), dy, dz)            # +x
        self.quad(mat, (x0, y0, z0), dx, dz)            # -y
        self.quad(mat, (x0, y1, z0), dz, dx)            # +y
        self.quad(mat, (x0, y0, z0), dy, dx)            # -z
        self.quad(mat, (x0, y0, z1), dx, dy)            # +z

    def cylinder(self, mat, centre, radius, height, sides):
        """A closed vertical cylinder standing on `centre`."""
        cx, cy, cz = centre
        ring = [(cx + radius * math.cos(2 * math.pi * k / sides), cz + radius * math.sin(2 * math.pi * k / sides)) for k in range(sides)]
        for k in range(sides):
            (xa, za), (xb, zb) = ring[k], ring[(k + 1) % sides]
            self.poly(mat, [(xa, cy, za), (xa, cy + height, za), (xb, cy + height, zb), (xb, cy, zb)])
        self.poly(mat, [(x, cy + height, z) for x, z in reversed(ring)])
        self.poly(mat, [(x, cy, z) for x, z in ring])


def room(m):
    w, h, d = 4.0, 2.8, 5.0
    m.quad("floor", (0, 0, 0), (0, 0, d), (w, 0, 0))
    m.quad("ceiling", (0, h, 0), (w, 0, 0), (0, 0, d))
    m.quad("wall", (0, 0, 0), (w, 0, 0), (0, h, 0))          # z = 0, facing +z
    m.quad("wall", (0, 0, d), (0, h, 0), (w, 0, 0))          # z = d, facing -z
    m.quad("wall", (0, 0, 0), (0, h, 0), (0, 0, d))          # x = 0, facing +x
    # x = w, facing -x, with a window (z 2.0-3.2, y 0.9-2.1) open to the sky
    for (z0, z1, y0, y1) in [(0, 2.0, 0, h), (3.2, d, 0, h), (2.0, 3.2, 0, 0.9), (2.0, 3.2, 2.1, h)]:
        m.quad("wall", (w, y0, z0), (0, 0, z1 - z0), (0, y1 - y0, 0))
    # window reveals (the wall is 20 cm thick)
    m.quad("wall", (w, 0.9, 2.0), (0, 0, 1.2), (0.2, 0, 0))
    m.quad("wall", (w, 2.1, 2.0), (0.2, 0, 0), (0, 0, 1.2))
    m.quad("wall", (w, 0.9, 2.0), (0.2, 0, 0), (0, 1.2, 0))
    m.quad("wall", (w, 0.9, 3.2), (0, 1.2, 0), (0.2, 0, 0))
    m.quad("lamp", (1.2, h - 0.01, 1.6), (0.6, 0, 0), (0, 0, 0.6))


def table_and_things(m):
    x0, z0, top = 1.2, 2.2, 0.75
    m.box("table", (x0, top - 0.03, z0), (x0 + 1.4, top, z0 + 0.8))
    for lx, lz in [(x0 + 0.03, z0 + 0.03), (x0 + 1.33, z0 + 0.03), (x0 + 0.03, z0 + 0.73), (x0 + 1.33, z0 + 0.73)]:
        m.box("table", (lx, 0, lz), (lx + 0.04, top - 0.03, lz + 0.04))
    # cubes of 5 mm to 8 cm, three colours each
    x = x0 + 0.08
    for s in [0.005, 0.01, 0.02, 0.04, 0.08]:
        for k, colour in enumerate(["red", "green", "blue"]):
            z = z0 + 0.1 + 0.2 * k
            m.box(colour, (x, top, z), (x + s, top + s, z + s))
        x += max(s, 0.02) + 0.06
    # pencils: 7 mm square, 15 cm long, lying side by side
    for k, colour in enumerate(["yellow", "red", "green", "blue", "yellow"]):
        z = z0 + 0.62 + 0.015 * k
        m.box(colour, (x0 + 0.6, top, z), (x0 + 0.75, top + 0.007, z + 0.007))
    # a mug: 24 sides of 1 cm
    m.cylinder("white", (x0 + 1.0, top, z0 + 0.3), 0.04, 0.1, 24)
    m.cylinder("blue", (x0 + 1.15, top, z0 + 0.55), 0.03, 0.12, 16)


def door(m):
    # a door on the z = 0 wall, 1 cm proud of it, with a lever handle and its rose
    m.box("door", (2.6, 0.0, 0.0), (3.5, 2.0, 0.01))
    m.box("brass", (2.72, 0.97, 0.01), (2.77, 1.03, 0.02))
    m.box("brass", (2.735, 0.99, 0.02), (2.755, 1.01, 0.06))
    m.box("brass", (2.735, 0.99, 0.06), (2.855, 1.01, 0.08))


def chair(m):
    x0, z0 = 1.6, 3.15
    m.box("table", (x0, 0.43, z0), (x0 + 0.45, 0.45, z0 + 0.45))
    for lx, lz in [(x0, z0), (x0 + 0.42, z0), (x0, z0 + 0.42), (x0 + 0.42, z0 + 0.42)]:
        m.box("black", (lx, 0, lz), (lx + 0.03, 0.43, lz + 0.03))
    m.box("table", (x0, 0.45, z0 + 0.42), (x0 + 0.45, 0.95, z0 + 0.45))
    m.box("red", (x0 + 0.03, 0.45, z0 + 0.03), (x0 + 0.42, 0.5, z0 + 0.4))


def shelf(m):
    # against the x = 0 wall: two boards with 30 books each, 2-4 cm thick
    rng = random.Random(7)
    for board_y in [0.9, 1.3]:
        m.box("table", (0.0, board_y - 0.02, 0.5), (0.25, board_y, 1.7))
        z = 0.52
        while z < 1.66:
            t = rng.uniform(0.02, 0.04)
            hgt = rng.uniform(0.18, 0.3)
            m.box(rng.choice(BOOK_COLOURS), (0.02, board_y, z), (0.02 + rng.uniform(0.15, 0.22), board_y + hgt, z + t))
            z += t + 0.002


def write(m):
    os.makedirs(OUT, exist_ok=True)
    lines = ["# Small things in a study (written by tools/make-small-things.py)", "mtllib room.mtl"]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in m.v]
    for mat, faces in m.groups.items():
        lines.append(f"usemtl {mat}")
        lines += ["f " + " ".join(str(i) for i in face) for face in faces]
    open(os.path.join(OUT, "room.obj"), "w").write("\n".join(lines) + "\n")
    mtl = []
    for name, (kd, ke) in MATERIALS.items():
        mtl += [f"newmtl {name}", "Kd %.3f %.3f %.3f" % kd]
        if ke:
            mtl.append("Ke %.3f %.3f %.3f" % ke)
        mtl.append("")
    open(os.path.join(OUT, "room.mtl"), "w").write("\n".join(mtl))
    open(os.path.join(OUT, "scene.toml"), "w").write(SCENE)


SCENE = """# Small things in a study: detail smaller than a texel and a grid cell at default settings
# (cubes of 5 mm to 8 cm, 7 mm pencils, a 24-sided mug, a 2 cm door lever, 3 cm chair legs,
# 60 books), each coloured unlike what it stands on. Written by tools/make-small-things.py.
name = "small-things"
mesh = "room.obj"

[sky]
radiance = [2.0, 2.1, 2.4]

# over the table, close enough that the small things cover many pixels
[[camera]]
name = "table"
eye = [1.75, 1.25, 3.55]
target = [1.85, 0.72, 2.55]
up = [0.0, 1.0, 0.0]
fov_y_deg = 45.0
size = [640, 360]

# the room from the corner by the shelf: door, chair, table, window
[[camera]]
name = "room"
eye = [0.4, 1.6, 4.7]
target = [2.6, 0.9, 1.0]
up = [0.0, 1.0, 0.0]
fov_y_deg = 70.0
size = [640, 360]

# the door's lever handle and the books, close
[[camera]]
name = "handle"
eye = [2.55, 1.15, 0.55]
target = [2.8, 1.0, 0.0]
up = [0.0, 1.0, 0.0]
fov_y_deg = 40.0
size = [640, 360]
"""


def main():
    m = Mesh()
    room(m)
    table_and_things(m)
    door(m)
    chair(m)
    shelf(m)
    write(m)
    tris = sum(len(f) - 2 for faces in m.groups.values() for f in faces)
    print(f"{OUT}: {tris} triangles, {len(m.groups)} materials")


if __name__ == "__main__":
    main()
