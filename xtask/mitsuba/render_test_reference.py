"""Renders the reference mean and per-sample variance of a Mitsuba test
scene as Mitsuba's render tests store them (refs/<name>_ref_rgb.exr and
refs/<name>_ref_rgb_var.exr, 32,000 spp, the rgb variant), for
twintrace's own gate scenes under fixtures/mitsuba. The scene's
integrator must be `moment`, whose two moments give the variance.

    python3 xtask/mitsuba/render_test_reference.py SCENE.xml [--spp 32000] [--chunk 1000]

The samples are rendered in chunks of `--chunk` (seeds 0, 1, ...) whose
moments are averaged in f64: Mitsuba's film sums a pixel's samples in
f32, which over 32,000 samples moves a mean by up to a few 10^-4 of
itself (a sky seen directly, one value in every sample, came out
0.024 % low in one scene and 0.030 % high in another) and gives such a
pixel a variance it does not have; over 1,000 it stays near 10^-5.

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
    parser.add_argument("--chunk", type=int, default=1000)
    parser.add_argument("--variant", default="scalar_rgb")
    args = parser.parse_args()
    mi.set_variant(args.variant)
    # The moment integrator's layers: the image (`<root>`, RGB) and its
    # nested integrator's first and second moments per sample in XYZ
    # (`_arg_0`, `m2__arg_0`), each chunk's weighted by its samples.
    total = 0
    sums = {"<root>": 0.0, "_arg_0": 0.0, "m2__arg_0": 0.0}
    seed = 0
    while total < args.spp:
        spp = min(args.chunk, args.spp - total)
        scene = mi.load_file(args.scene, spp=spp)
        mi.render(scene, spp=spp, seed=seed)
        layers = dict(scene.sensors()[0].film().bitmap(raw=False).split())
        for name in sums:
            sums[name] = sums[name] + spp * np.array(layers[name], dtype=np.float64)
        total += spp
        seed += 1
    mean = (sums["<root>"] / total).astype(np.float32)[..., :3]
    m1 = sums["_arg_0"] / total
    m2 = sums["m2__arg_0"] / total
    # The variance is m2 - m1^2 in XYZ, stored converted to RGB by the
    # colour matrix, as mitsuba-data's references store theirs (the z-test
    # converts it back to XYZ).
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
