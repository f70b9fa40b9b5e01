"""Writes the assets of twintrace's Mitsuba gate scene
fixtures/mitsuba/frames (run from the repository root):

- textures/bumps.png: a 32 x 32 tangent-space normal map (8-bit RGB,
  `(n + 1) / 2`) of the height field 0.35 sin(4 pi u) sin(4 pi v);
- meshes/ball.obj: a unit UV sphere, 16 segments around z by 10 from
  pole to pole, with normals and texture coordinates (u around the
  axis, v from the bottom pole; the poles' triangles share a vertex
  per segment so that their parameterization is not degenerate).

    python3 xtask/mitsuba/frames_assets.py
"""
import math
import struct
import zlib

ROOT = "fixtures/mitsuba/frames"


def png(path, width, height, rows):
    """An 8-bit RGB PNG of `rows` (bytes per row, top first)."""
    raw = b"".join(b"\x00" + r for r in rows)

    def chunk(kind, data):
        c = kind + data
        return struct.pack(">I", len(data)) + c + struct.pack(">I", zlib.crc32(c))

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(raw, 9)))
        f.write(chunk(b"IEND", b""))


def bumps():
    n = 32
    rows = []
    for j in range(n):
        row = bytearray()
        for i in range(n):
            u, v = (i + 0.5) / n, 1.0 - (j + 0.5) / n
            k = 0.35 * 4.0 * math.pi
            dhdu = k * math.cos(4 * math.pi * u) * math.sin(4 * math.pi * v)
            dhdv = k * math.sin(4 * math.pi * u) * math.cos(4 * math.pi * v)
            x, y, z = -dhdu, -dhdv, 1.0
            l = math.sqrt(x * x + y * y + z * z)
            for c in (x / l, y / l, z / l):
                row.append(max(0, min(255, round((c + 1.0) * 0.5 * 255.0))))
        rows.append(bytes(row))
    png(f"{ROOT}/textures/bumps.png", n, n, rows)


def ball():
    seg, rings = 16, 10
    lines = ["# A unit UV sphere for twintrace's Mitsuba gate scene frames",
             "# (xtask/mitsuba/frames_assets.py)."]
    vs, vns, vts = [], [], []
    index = {}
    for r in range(rings + 1):
        theta = math.pi * r / rings
        for s in range(seg + 1):
            phi = 2 * math.pi * s / seg
            p = (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), -math.cos(theta))
            index[(r, s)] = len(vs) + 1
            vs.append(p)
            vns.append(p)
            vts.append((s / seg, r / rings))
    for p in vs:
        lines.append("v %.6f %.6f %.6f" % p)
    for n in vns:
        lines.append("vn %.6f %.6f %.6f" % n)
    for t in vts:
        lines.append("vt %.6f %.6f" % t)
    for r in range(rings):
        for s in range(seg):
            a, b = index[(r, s)], index[(r, s + 1)]
            c, d = index[(r + 1, s + 1)], index[(r + 1, s)]
            # Counter-clockwise seen from outside.
            if r > 0:
                lines.append("f %d/%d/%d %d/%d/%d %d/%d/%d" % (a, a, a, b, b, b, c, c, c))
            if r < rings - 1:
                lines.append("f %d/%d/%d %d/%d/%d %d/%d/%d" % (a, a, a, c, c, c, d, d, d))
    with open(f"{ROOT}/meshes/ball.obj", "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    bumps()
    ball()
