"""Writes the height map of twintrace's Mitsuba gate scene
fixtures/mitsuba/bumps (run from the repository root):

- textures/height.png: a 32 x 32 grey 8-bit PNG (every channel alike, so
  Mitsuba and twintrace read its one channel as it is) of the height
  0.5 + 0.4 sin(4 pi u) sin(2 pi v) + 0.1 u, read `raw` (v up the image,
  row 0 its top). Not symmetric in u or v, so that a gradient read with
  either axis reversed bends the normals elsewhere.

    python3 xtask/mitsuba/bumps_assets.py
"""
import math
import sys

sys.path.insert(0, "xtask/mitsuba")
from frames_assets import png  # noqa: E402

ROOT = "fixtures/mitsuba/bumps"


def height():
    n = 32
    rows = []
    for j in range(n):
        row = bytearray()
        for i in range(n):
            u, v = (i + 0.5) / n, 1.0 - (j + 0.5) / n
            h = 0.5 + 0.4 * math.sin(4 * math.pi * u) * math.sin(2 * math.pi * v) + 0.1 * u
            g = max(0, min(255, round(h * 255.0)))
            row += bytes((g, g, g))
        rows.append(bytes(row))
    png(f"{ROOT}/textures/height.png", n, n, rows)


if __name__ == "__main__":
    height()
