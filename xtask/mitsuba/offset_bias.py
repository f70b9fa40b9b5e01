#!/usr/bin/env python3
"""Mitsuba's ray-spawn offset darkens a faceted glass sphere's rim.

Usage: offset_bias.py [SPP] (default 4096; MITSUBA_VARIANT as render.py,
default cuda_ad_rgb; on a CPU llvm_ad_rgb with DRJIT_LIBLLVM_PATH). The
pack's `run.sh --offset-bias` runs it with the packed wheels.

One scene, rendered three times, each time translated as a whole (camera
and sphere; the sky is a lookup by direction), so that in exact
arithmetic the three images are one. Mitsuba's own plugins only
(`dielectric`, `path`, `envmap`, a `mesh` with vertex normals), none of
twintrace's: a glass sphere (IOR 1.5) made as a 32 x 16 UV sphere of
radius 1 whose vertex normals are its positions (the glTF sphere of
fixtures/scenes/gltf-materials.json), under that scene's sky, seen from
5.6 away (48x48, 24 degrees, depth 16).

Mitsuba starts every ray it spawns at a surface (`spawn_ray`) from the
hit point moved along the geometric normal by (1 + max|p|) * 8.94e-5
(`math::RayEpsilon`, a constant): 1.8e-4 with the sphere at the origin,
up to 6.7e-4 with the camera there (as `twintrace export-mitsuba` places
scenes), 9.1e-3 with the sphere at x = 100. A ray entering at the rim
meets the next facet at a grazing angle a short chord away; starting it
further inside moves that hit along the facet, where the interpolated
normal decides whether its total internal reflection leaves the sphere,
and the image darkens as the offset grows (docs/gates.md,
gltf-materials). Measured (llvm_ad_rgb, 4,096 spp, 11 s): the camera at
the origin 4.2-4.8e-4 darker than the sphere there (Welch t -8.9,
-12.5, -35.2), the sphere at x = 100 1.7-2.0e-3 darker (t -36, -49,
-110).

Prints each render's image sum, and for the two moved ones their
relative difference and Welch t (16 passes' spread) against the render
with the sphere at the origin.
"""
import math
import os
import sys

import numpy as np
import drjit as dr
import mitsuba as mi

SEGMENTS, RINGS = 32, 16
PASSES = 16
# Mitsuba 3.9.1's math::RayEpsilon (float variants).
RAY_EPSILON = 8.940696716308594e-05


def uv_sphere():
    """examples/gen_fixtures.rs's sphere: positions (= normals), faces."""
    pos, faces = [], []
    for r in range(RINGS + 1):
        theta = math.pi * r / RINGS
        for s in range(SEGMENTS + 1):
            phi = 2.0 * math.pi * s / SEGMENTS
            pos.append((math.sin(theta) * math.cos(phi), math.cos(theta),
                        math.sin(theta) * math.sin(phi)))
    row = SEGMENTS + 1
    for r in range(RINGS):
        for s in range(SEGMENTS):
            a, b = r * row + s, r * row + s + 1
            c, d = a + row, b + row
            if r != 0:
                faces.append((a, b, c))
            if r != RINGS - 1:
                faces.append((b, d, c))
    return np.array(pos, dtype=np.float32), np.array(faces, dtype=np.uint32)


def sky():
    """gltf-materials' sky, horizon (0.7, 0.7, 0.7) to zenith (0.2, 0.3,
    0.6) linear in cos(theta), rows at theta = pi j / (h - 1)."""
    h, w = 1024, 8
    t = 0.5 * (np.cos(np.pi * np.arange(h) / (h - 1)) + 1.0)
    horizon, zenith = np.array([0.7, 0.7, 0.7]), np.array([0.2, 0.3, 0.6])
    rows = horizon[None, :] * (1.0 - t[:, None]) + zenith[None, :] * t[:, None]
    image = np.repeat(rows[:, None, :], w, axis=1).astype(np.float32)
    return mi.Bitmap(np.ascontiguousarray(image))


def scene(shift):
    pos, faces = uv_sphere()
    mesh = mi.Mesh("glass", len(pos), len(faces), has_vertex_normals=True)
    params = mi.traverse(mesh)
    params["vertex_positions"] = dr.ravel(mi.Point3f(
        pos[:, 0] + shift[0], pos[:, 1] + shift[1], pos[:, 2] + shift[2]))
    params["vertex_normals"] = dr.ravel(mi.Normal3f(pos[:, 0], pos[:, 1], pos[:, 2]))
    params["faces"] = dr.ravel(mi.Vector3u(faces[:, 0], faces[:, 1], faces[:, 2]))
    params.update()
    mesh.set_bsdf(mi.load_dict({"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}))
    eye = np.array([-1.1, 0.6, 5.5]) + shift
    return mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 16},
        "sensor": {
            "type": "perspective", "fov": 24.0, "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(
                origin=eye.tolist(), target=shift.tolist(), up=[0, 1, 0]),
            "sampler": {"type": "independent"},
            "film": {"type": "hdrfilm", "width": 48, "height": 48,
                     "pixel_format": "rgb", "rfilter": {"type": "box"}},
        },
        "sphere": mesh,
        "sky": {"type": "envmap", "bitmap": sky()},
    })


def render(shift, spp):
    """The image sum's mean over PASSES passes and the variance of that mean."""
    s = scene(np.array(shift, dtype=np.float64))
    sums = np.array([
        np.array(mi.render(s, spp=spp // PASSES, seed=k), dtype=np.float64)[:, :, :3].sum(axis=(0, 1))
        for k in range(PASSES)
    ])
    return sums.mean(axis=0), sums.var(axis=0, ddof=1) / PASSES


def main():
    mi.set_variant(os.environ.get("MITSUBA_VARIANT", "cuda_ad_rgb"))
    spp = int(sys.argv[1]) if len(sys.argv) > 1 else 4096
    if spp < PASSES:
        sys.exit(f"offset_bias.py: SPP {spp} is below the {PASSES} passes")
    print(f"Mitsuba {mi.__version__} ({mi.variant()}), {PASSES} passes x {spp // PASSES} spp")

    def offset(shift):
        # Mitsuba's offset at the sphere's point of largest max|p|.
        return (1.0 + max(abs(c) for c in shift) + 1.0) * RAY_EPSILON

    base_shift = (0.0, 0.0, 0.0)
    base, base_var = render(base_shift, spp)
    print(f"sphere at the origin (offset {offset(base_shift):.1e}): image sum {np.round(base, 3)}")
    for label, shift in [("camera at the origin", (1.1, -0.6, -5.5)),
                         ("sphere at x = 100", (100.0, 0.0, 0.0))]:
        m, v = render(shift, spp)
        t = (m - base) / np.sqrt(v + base_var)
        print(f"{label} (offset up to {offset(shift):.1e}): image sum {np.round(m, 3)}, "
              f"relative {np.round(m / base - 1.0, 5)}, Welch t {np.round(t, 1)}")


if __name__ == "__main__":
    main()
