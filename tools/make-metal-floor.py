#!/usr/bin/env python3
"""Writes scenes/metal-floor/: a glTF room whose metal varies over its surfaces (issue 29,
metallicRoughness textures). A closed 2 m box (white walls, a red left and a green right wall)
lit by a small square emitter under its ceiling. Its floor has a base colour texture (two tones)
and a metallic-roughness texture: a checker of glossy metal tiles (roughness 0.45, GGX alpha
0.2) and matte dielectric tiles, with one row of smoother metal (roughness 0.3, alpha 0.09). A
gold column stands on it, metal everywhere, its roughness growing from 0.25 at its foot to 0.6
at its top. vlf splits both per texel (src/scene/gltf/metal_rough.rs); tools/mitsuba/reference.py
reads the same glTF with its own per-texel rule, and tools/glossy-mitsuba.sh compares them.
Standard library only."""
import json, os, struct, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scene_png import scene_folder, write_png  # noqa: E402

here = scene_folder("metal-floor")


# the floor: 4 x 4 tiles of 16 texels; tile (i, j) a glossy metal where i + j is even, matte
# where odd; the top row's metal tiles smoother
TILE, TILES = 16, 4
N = TILE * TILES


def floor_base(x, y):
    i, j = x // TILE, y // TILE
    # a light grey and a warm tone (sRGB)
    return (200, 200, 205) if (i + 2 * j) % 3 else (214, 170, 120)


def floor_metal_rough(x, y):
    i, j = x // TILE, y // TILE
    metal = (i + j) % 2 == 0
    rough = 0.3 if (metal and j == 0) else (0.45 if metal else 0.8)
    # glTF: roughness in green, metallic in blue (linear)
    return (0, round(rough * 255), 255 if metal else 0)


# the column's roughness from 0.25 (its foot, v = 0: the image's bottom row) to 0.6 (top)
COLUMN_H = 32


def column_metal_rough(x, y):
    t = (COLUMN_H - 1 - y) / (COLUMN_H - 1)
    return (0, round((0.25 + 0.35 * t) * 255), 255)


write_png(here, "floor-base.png", N, N, floor_base)
write_png(here, "floor-metal-rough.png", N, N, floor_metal_rough)
write_png(here, "column-metal-rough.png", 4, COLUMN_H, column_metal_rough)

# geometry: quads as two triangles, counter-clockwise seen from the room
positions, uvs, indices = [], [], []
primitives = []


def quad(corners, material, uv=None):
    """One quad (corners counter-clockwise seen from its front) as a primitive of its own."""
    first_index = len(indices)
    base = len(positions)
    positions.extend(corners)
    uvs.extend(uv or [(0.0, 0.0)] * 4)
    indices.extend([base, base + 1, base + 2, base, base + 2, base + 3])
    primitives.append((first_index, 6, material))


S, H = 1.0, 2.0
# floor (faces up), uv over the whole floor (glTF: v = 0 at the image's top)
quad([(-S, 0, S), (S, 0, S), (S, 0, -S), (-S, 0, -S)], "floor", [(0, 1), (1, 1), (1, 0), (0, 0)])
quad([(-S, H, -S), (S, H, -S), (S, H, S), (-S, H, S)], "white")  # ceiling (faces down)
quad([(-S, 0, -S), (S, 0, -S), (S, H, -S), (-S, H, -S)], "white")  # back wall (faces +z)
quad([(S, 0, S), (-S, 0, S), (-S, H, S), (S, H, S)], "white")  # front wall (faces -z)
quad([(-S, 0, S), (-S, 0, -S), (-S, H, -S), (-S, H, S)], "red")  # left wall (faces +x)
quad([(S, 0, -S), (S, 0, S), (S, H, S), (S, H, -S)], "green")  # right wall (faces -x)
# the emitter: a 0.5 m square 1 cm under the ceiling, facing down
L, Y = 0.25, H - 0.01
quad([(-L, Y, -L), (L, Y, -L), (L, Y, L), (-L, Y, L)], "light")
# the column: 0.4 x 1.1 x 0.4 at (0.35, -0.3), four sides and a top, v up its height
cx, cz, w, ch = 0.35, -0.3, 0.2, 1.1
x0, x1, z0, z1 = cx - w, cx + w, cz - w, cz + w
up = [(0, 1), (1, 1), (1, 0), (0, 0)]
quad([(x0, 0, z1), (x1, 0, z1), (x1, ch, z1), (x0, ch, z1)], "column", up)  # +z
quad([(x1, 0, z0), (x0, 0, z0), (x0, ch, z0), (x1, ch, z0)], "column", up)  # -z
quad([(x1, 0, z1), (x1, 0, z0), (x1, ch, z0), (x1, ch, z1)], "column", up)  # +x
quad([(x0, 0, z0), (x0, 0, z1), (x0, ch, z1), (x0, ch, z0)], "column", up)  # -x
quad([(x0, ch, z1), (x1, ch, z1), (x1, ch, z0), (x0, ch, z0)], "column", [(0, 0)] * 4)  # top

materials = {
    "white": {"pbrMetallicRoughness": {"baseColorFactor": [0.73, 0.73, 0.73, 1], "metallicFactor": 0, "roughnessFactor": 1}},
    "red": {"pbrMetallicRoughness": {"baseColorFactor": [0.63, 0.065, 0.05, 1], "metallicFactor": 0, "roughnessFactor": 1}},
    "green": {"pbrMetallicRoughness": {"baseColorFactor": [0.14, 0.45, 0.091, 1], "metallicFactor": 0, "roughnessFactor": 1}},
    "light": {"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0, "roughnessFactor": 1},
              "emissiveFactor": [1.0, 0.85, 0.6], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 17.0}}},
    "floor": {"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "baseColorTexture": {"index": 0},
                                       "metallicFactor": 1, "roughnessFactor": 1, "metallicRoughnessTexture": {"index": 1}}},
    "column": {"pbrMetallicRoughness": {"baseColorFactor": [0.95, 0.75, 0.4, 1],
                                        "metallicFactor": 1, "roughnessFactor": 1, "metallicRoughnessTexture": {"index": 2}}},
}
names = list(materials)
blob = b"".join(struct.pack("<3f", *p) for p in positions)
uv_offset = len(blob)
blob += b"".join(struct.pack("<2f", *t) for t in uvs)
index_offset = len(blob)
blob += b"".join(struct.pack("<I", i) for i in indices)
open(os.path.join(here, "metal-floor.bin"), "wb").write(blob)
lo = [min(p[k] for p in positions) for k in range(3)]
hi = [max(p[k] for p in positions) for k in range(3)]
accessors = [
    {"bufferView": 0, "componentType": 5126, "count": len(positions), "type": "VEC3", "min": lo, "max": hi},
    {"bufferView": 1, "componentType": 5126, "count": len(uvs), "type": "VEC2"},
]
mesh_primitives = []
for first, count, material in primitives:
    accessors.append({"bufferView": 2, "byteOffset": first * 4, "componentType": 5125, "count": count, "type": "SCALAR"})
    mesh_primitives.append({"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": len(accessors) - 1,
                            "material": names.index(material)})
doc = {
    "asset": {"version": "2.0", "generator": "vlf tools/make-metal-floor.py"},
    "extensionsUsed": ["KHR_materials_emissive_strength"],
    "scene": 0,
    "scenes": [{"nodes": [0]}],
    "nodes": [{"mesh": 0, "name": "room"}],
    "meshes": [{"primitives": mesh_primitives}],
    "accessors": accessors,
    "materials": [dict(name=n, **materials[n]) for n in names],
    "textures": [{"source": 0}, {"source": 1}, {"source": 2}],
    "images": [{"uri": "floor-base.png"}, {"uri": "floor-metal-rough.png"}, {"uri": "column-metal-rough.png"}],
    "buffers": [{"uri": "metal-floor.bin", "byteLength": len(blob)}],
    "bufferViews": [
        {"buffer": 0, "byteOffset": 0, "byteLength": uv_offset},
        {"buffer": 0, "byteOffset": uv_offset, "byteLength": index_offset - uv_offset},
        {"buffer": 0, "byteOffset": index_offset, "byteLength": len(blob) - index_offset},
    ],
}
open(os.path.join(here, "metal-floor.gltf"), "w").write(json.dumps(doc, indent=1) + "\n")
open(os.path.join(here, "scene.toml"), "w").write('''# A closed room whose floor is a checker of glossy metal and matte tiles and whose gold column's
# roughness grows with its height: glTF metallicRoughness textures, split per texel.
# Written by tools/make-metal-floor.py; tools/glossy-mitsuba.sh compares it with Mitsuba 3.
name = "metal-floor"
mesh = "metal-floor.gltf"

[[camera]]
name = "front"
eye = [0.0, 1.1, 0.95]
target = [0.05, 0.35, -0.4]
up = [0.0, 1.0, 0.0]
fov_y_deg = 60.0
size = [512, 512]

# low over the floor: the metal tiles reflect the walls and the column, blurred
[[camera]]
name = "low"
eye = [-0.8, 0.35, 0.85]
target = [0.2, 0.3, -0.5]
up = [0.0, 1.0, 0.0]
fov_y_deg = 55.0
size = [512, 512]
''')
print(f"wrote {here}: {len(indices) // 3} triangles")
