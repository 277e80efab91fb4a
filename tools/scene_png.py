"""What the make-*.py scene scripts share: the folder a scene goes into and the PNG writer (8-bit
RGB or RGBA, one IDAT, standard library only: the scripts run on a fresh machine without
Pillow)."""
import os, struct, zlib


def scene_folder(name):
    """scenes/<name> of this repository, created if missing."""
    folder = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes", name)
    os.makedirs(folder, exist_ok=True)
    return folder


def write_png(folder, file, w, h, pixel, alpha=False):
    """Write a w x h PNG to folder/file; pixel(x, y) gives the (r, g, b) or, with alpha, the
    (r, g, b, a) bytes of column x of row y (rows from the top)."""
    raw = b"".join(b"\0" + bytes(c for x in range(w) for c in pixel(x, y)) for y in range(h))
    chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)
    colour_type = 6 if alpha else 2
    data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, colour_type, 0, 0, 0))
    data += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    with open(os.path.join(folder, file), "wb") as f:
        f.write(data)
