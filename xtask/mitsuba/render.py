#!/usr/bin/env python3
"""Renders the scenes that `twintrace export-mitsuba` wrote, with Mitsuba 3.

Usage: render.py OUT_DIR SCENE_DIR... (each SCENE_DIR holds a scene.xml).
For each SCENE_DIR named NAME it writes OUT_DIR/NAME.exr in twintrace's
layout: R, G, B (the mean of PASSES independent passes of PASS_SPP samples
per pixel), variance.R/G/B (the variance of that mean, from the spread of
the pass means), skewness.R/G/B (M3 / M2^1.5 of the pass means, the
skewness of the mean) and an `spp` attribute (PASSES * PASS_SPP); and
OUT_DIR/NAME.json with the settings, versions and timings.

Run on a machine with an NVIDIA GPU (variant cuda_ad_rgb) or, slower,
with MITSUBA_VARIANT=llvm_ad_rgb where LLVM 16 or newer is installed
(DRJIT_LIBLLVM_PATH names it), or scalar_rgb (slowest: the plugins run in
Python a ray at a time). twintrace's plugins (plugins/, beside this file:
the reference's dielectric, fuzzy metal, GGX and 3-D checker) are
registered before any scene loads.
"""
import json
import os
import struct
import sys
import time

import numpy as np
import drjit as dr
import mitsuba as mi

PASSES = int(os.environ.get("PASSES", "64"))
PASS_SPP = int(os.environ.get("PASS_SPP", "4096"))


def write_exr(path, planes, attributes):
    """An uncompressed single-part scan-line OpenEXR file of 32-bit float
    channels; `planes` maps channel names to HxW arrays; `attributes` maps
    names to ints (type int) or strings (type string)."""
    names = sorted(planes)
    height, width = planes[names[0]].shape

    def attr(name, kind, payload):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(payload)) + payload

    chlist = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for n in names) + b"\0"
    box = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    header = b"".join([
        attr("channels", "chlist", chlist),
        attr("compression", "compression", b"\0"),
        attr("dataWindow", "box2i", box),
        attr("displayWindow", "box2i", box),
        attr("lineOrder", "lineOrder", b"\0"),
        attr("pixelAspectRatio", "float", struct.pack("<f", 1.0)),
        attr("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0)),
        attr("screenWindowWidth", "float", struct.pack("<f", 1.0)),
    ])
    for name, value in attributes.items():
        if isinstance(value, int):
            header += attr(name, "int", struct.pack("<i", value))
        else:
            header += attr(name, "string", value.encode())
    header = struct.pack("<ii", 20000630, 2) + header + b"\0"
    line_bytes = 4 * width * len(names)
    first = len(header) + 8 * height
    offsets = b"".join(struct.pack("<Q", first + y * (8 + line_bytes)) for y in range(height))
    with open(path + ".tmp", "wb") as f:
        f.write(header + offsets)
        for y in range(height):
            f.write(struct.pack("<ii", y, line_bytes))
            for n in names:
                f.write(planes[n][y].astype("<f4").tobytes())
    os.replace(path + ".tmp", path)


def render(scene_dir, out_dir):
    name = os.path.basename(os.path.normpath(scene_dir))
    t0 = time.perf_counter()
    scene = mi.load_file(os.path.join(scene_dir, "scene.xml"))
    # Warm-up: Dr.Jit compiles the kernels on first use.
    dr.sync_thread()
    mi.render(scene, spp=16, seed=2**31)
    dr.sync_thread()
    t1 = time.perf_counter()
    passes = []
    for k in range(PASSES):
        image = mi.render(scene, spp=PASS_SPP, seed=k)
        passes.append(np.array(image, dtype=np.float64)[:, :, :3])
    dr.sync_thread()
    t2 = time.perf_counter()
    p = np.stack(passes)
    mean = p.mean(axis=0)
    d = p - mean
    m2 = (d * d).sum(axis=0)
    m3 = (d * d * d).sum(axis=0)
    variance = m2 / (PASSES - 1) / PASSES
    with np.errstate(divide="ignore", invalid="ignore"):
        skewness = np.where(m2 > 0, m3 / np.power(m2, 1.5), 0.0)
    planes = {}
    for c, ch in enumerate("RGB"):
        planes[ch] = mean[:, :, c]
        planes["variance." + ch] = variance[:, :, c]
        planes["skewness." + ch] = skewness[:, :, c]
    spp = PASSES * PASS_SPP
    integrator = scene.integrator().class_name().lower().replace("integrator", "")
    software = f"Mitsuba {mi.__version__} ({mi.variant()}, {integrator or 'path'} integrator)"
    write_exr(os.path.join(out_dir, name + ".exr"), planes, {"spp": spp, "software": software})
    info = {
        "name": name,
        "software": software,
        "drjit": dr.__version__,
        "passes": PASSES,
        "pass_spp": PASS_SPP,
        "spp": spp,
        "size": f"{mean.shape[1]}x{mean.shape[0]}",
        "load_and_warm_up_s": round(t1 - t0, 3),
        "render_s": round(t2 - t1, 3),
        "nonfinite": int((~np.isfinite(p)).sum()),
    }
    with open(os.path.join(out_dir, name + ".json"), "w") as f:
        json.dump(info, f, indent=1)
    print(json.dumps(info), flush=True)


def main():
    if len(sys.argv) < 3:
        sys.exit("usage: render.py OUT_DIR SCENE_DIR...")
    mi.set_variant(os.environ.get("MITSUBA_VARIANT", "cuda_ad_rgb"))
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "plugins"))
    import twintrace_plugins

    twintrace_plugins.register()
    out_dir = sys.argv[1]
    os.makedirs(out_dir, exist_ok=True)
    for scene_dir in sys.argv[2:]:
        render(scene_dir, out_dir)


if __name__ == "__main__":
    main()
