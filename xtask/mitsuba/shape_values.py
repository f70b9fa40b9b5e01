"""Writes what Mitsuba 3's own shape plugins give for rays shot at
twintrace's shape fixtures (fixtures/mitsuba_shapes/*.xml), for
tests/reference/mitsuba_shapes.rs to hold twintrace's shapes to.

    python3 xtask/mitsuba/shape_values.py [--out fixtures/mitsuba_shapes]

For each scene NAME.xml it writes NAME.f32: per ray 22 f32 (little
endian): origin (3), unit direction (3), hit (1 or 0), t, the hit point
(3), the geometric normal si.n (3), the shading normal si.sh_frame.n (3),
si.uv (2) and si.dp_du (3), zeros where the ray misses. The rays: for
each shape of the scene, RAYS aimed from outside its bounding box at a
point inside it, and RAYS / 4 from points inside the box (seeded, so the
file is the same on every run). It also writes blob.vol, the grid
grids.xml reads: 12 samples a side of the signed distance (in samples)
to a torus of radii 3.3 and 1.6 about an axis tilted off the grid's,
centred off the grid's centre.

Needs Mitsuba 3 (`pip install mitsuba==3.9.1 numpy`); runs on the CPU
(`scalar_rgb`).
"""

import argparse
import os
import struct

import mitsuba as mi
import numpy as np

RAYS = 1000


def write_blob(path):
    n = 12
    idx = np.arange(n, dtype=np.float64)
    z, y, x = np.meshgrid(idx, idx, idx, indexing="ij")
    c = np.array([5.7, 5.2, 5.9])
    p = np.stack([x - c[0], y - c[1], z - c[2]], axis=-1)
    axis = np.array([0.3, 1.0, 0.2])
    axis /= np.linalg.norm(axis)
    h = p @ axis
    radial = np.linalg.norm(p - h[..., None] * axis, axis=-1)
    sdf = np.sqrt((radial - 3.3) ** 2 + h**2) - 1.6
    header = b"VOL" + bytes([3]) + struct.pack("<5i", 1, n, n, n, 1)
    header += struct.pack("<6f", 0.0, 0.0, 0.0, 1.0, 1.0, 1.0)
    with open(path, "wb") as f:
        f.write(header + sdf.astype("<f4").tobytes())


def rays_for(scene, rng):
    out = []
    for shape in scene.shapes():
        b = shape.bbox()
        lo, hi = np.array(b.min), np.array(b.max)
        size = hi - lo
        diag = np.linalg.norm(size)
        for k in range(RAYS + RAYS // 4):
            target = lo + size * rng.uniform(0.05, 0.95, 3)
            d = rng.normal(size=3)
            d /= np.linalg.norm(d)
            if k < RAYS:
                o = target - (2.0 * diag + 1.0) * d
            else:
                o = target
            out.append((o.astype(np.float32), d.astype(np.float32)))
    return out


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", default="fixtures/mitsuba_shapes")
    args = parser.parse_args()
    mi.set_variant("scalar_rgb")
    write_blob(os.path.join(args.out, "blob.vol"))
    for name in ["quadrics", "grids"]:
        scene = mi.load_file(os.path.join(args.out, name + ".xml"))
        rng = np.random.default_rng(20261207)
        records = []
        for o, d in rays_for(scene, rng):
            ray = mi.Ray3f(mi.Point3f(*o), mi.Vector3f(*d))
            si = scene.ray_intersect(ray)
            rec = list(o) + list(d)
            if si.is_valid():
                rec += [1.0, si.t] + list(si.p) + list(si.n) + list(si.sh_frame.n)
                rec += list(si.uv) + list(si.dp_du)
            else:
                rec += [0.0] * 16
            records.append(rec)
        values = np.array(records, dtype="<f4")
        path = os.path.join(args.out, name + ".f32")
        values.tofile(path)
        hits = int(values[:, 6].sum())
        print(path, values.shape, f"{hits} hits")


if __name__ == "__main__":
    main()
