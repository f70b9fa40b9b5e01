"""Writes fixtures/mitsuba/attributes/meshes/ball.ply: a UV sphere of
radius 1 (12 rings of 16 segments, triangles only, as Mitsuba's `ply`
reads) with mesh attributes for the attributes gate scene: per vertex
`color_0..2` (Mitsuba's `vertex_color`: a colour varying with the
position) and `weight_0` (`vertex_weight`, one channel), per face
`col_r`, `col_g`, `col_b` (`face_col_color`: a colour from the face's
index). Binary little endian, all float.

    python3 xtask/mitsuba/attribute_mesh.py [OUT]

Needs numpy.
"""

import sys

import numpy as np


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "fixtures/mitsuba/attributes/meshes/ball.ply"
    rings, segments = 12, 16
    verts = []
    for i in range(rings + 1):
        theta = np.pi * i / rings
        for j in range(segments + 1):
            phi = 2.0 * np.pi * j / segments
            verts.append((np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)))
    verts = np.array(verts, dtype=np.float32)
    faces = []
    for i in range(rings):
        for j in range(segments):
            a = i * (segments + 1) + j
            b = a + segments + 1
            if i != 0:
                faces.append((a, b, a + 1))
            if i != rings - 1:
                faces.append((a + 1, b, b + 1))
    colour = 0.5 + 0.45 * verts[:, [0, 1, 2]] * np.array([1.0, -1.0, 1.0], dtype=np.float32)
    weight = (0.2 + 0.7 * (0.5 + 0.5 * verts[:, 2])).astype(np.float32)
    k = np.arange(len(faces), dtype=np.float64)
    face_colour = np.stack(
        [(k * 0.618034) % 1.0, (k * 0.414214) % 1.0, (k * 0.732051) % 1.0], axis=1
    ).astype(np.float32) * 0.8 + 0.1
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(verts)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property float color_0\nproperty float color_1\nproperty float color_2\n"
        "property float weight_0\n"
        f"element face {len(faces)}\n"
        "property list uchar int vertex_indices\n"
        "property float col_r\nproperty float col_g\nproperty float col_b\n"
        "end_header\n"
    )
    with open(out, "wb") as f:
        f.write(header.encode("ascii"))
        for v, c, w in zip(verts, colour.astype(np.float32), weight):
            f.write(np.array([*v, *c, w], dtype="<f4").tobytes())
        for face, c in zip(faces, face_colour):
            f.write(np.array([3], dtype="u1").tobytes())
            f.write(np.array(face, dtype="<i4").tobytes())
            f.write(np.array(c, dtype="<f4").tobytes())
    print(f"wrote {out}: {len(verts)} vertices, {len(faces)} faces")


if __name__ == "__main__":
    main()
