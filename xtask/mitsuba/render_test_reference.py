"""Renders the reference mean and per-sample variance of a Mitsuba test
scene as Mitsuba's render tests store them (refs/<name>_ref_rgb.exr and
refs/<name>_ref_rgb_var.exr, 32,000 spp, the rgb variant), for
twintrace's own gate scenes under fixtures/mitsuba. The scene's
integrator must be `moment`, whose two moments give the variance.

    python3 xtask/mitsuba/render_test_reference.py SCENE.xml [--spp 32000]

Needs Mitsuba 3 (`pip install mitsuba==3.9.1 numpy`); runs on the CPU
(`scalar_rgb`).
"""

import argparse
import os

import mitsuba as mi
import numpy as np


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("scene")
    parser.add_argument("--spp", type=int, default=32000)
    parser.add_argument("--variant", default="scalar_rgb")
    args = parser.parse_args()
    mi.set_variant(args.variant)
    scene = mi.load_file(args.scene, spp=args.spp)
    mi.render(scene, spp=args.spp)
    film = scene.sensors()[0].film()
    layers = dict(film.bitmap(raw=False).split())
    # The moment integrator's layers: the image (`<root>`, RGB) and its
    # nested integrator's first and second moments per sample in XYZ
    # (`_arg_0`, `m2__arg_0`). The variance is m2 - m1^2 in XYZ, stored
    # converted to RGB by the colour matrix, as mitsuba-data's references
    # store theirs (the z-test converts it back to XYZ).
    mean = np.array(layers["<root>"], dtype=np.float32)[..., :3]
    m1 = np.array(layers["_arg_0"], dtype=np.float64)
    m2 = np.array(layers["m2__arg_0"], dtype=np.float64)
    var_xyz = np.maximum(m2 - m1 * m1, 0.0).astype(np.float32)
    var = np.array(
        mi.Bitmap(var_xyz, mi.Bitmap.PixelFormat.XYZ).convert(
            mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False
        )
    )
    folder = os.path.join(os.path.dirname(os.path.abspath(args.scene)), "refs")
    os.makedirs(folder, exist_ok=True)
    stem = os.path.splitext(os.path.basename(args.scene))[0].rsplit("_", 1)[0]
    for suffix, image in (("", mean), ("_var", var)):
        path = os.path.join(folder, f"{stem}_ref_rgb{suffix}.exr")
        mi.Bitmap(image.astype(np.float32), mi.Bitmap.PixelFormat.RGB).write(path)
        print(path, image.shape, image.mean(axis=(0, 1)))


if __name__ == "__main__":
    main()
