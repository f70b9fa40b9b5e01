#!/usr/bin/env python3
"""Times Mitsuba 3 renders of one exported scene at doubling spp.

Usage: time_to_error.py SCENE_DIR OUT_DIR

For each spp of the ladder LADDER_MIN (default 1), twice that, ...
LADDER_MAX (default 1024) it
renders REPS (default 5) times with different seeds and writes the first
render as OUT_DIR/mitsuba-SPP.exr (R, G, B; the `spp` attribute) and every
render's time into OUT_DIR/mitsuba-times.json. The time of one render is
`mi.render` plus `dr.sync_thread()`: the kernels run to completion, after a
warm-up render of the same spp compiled and cached them (Dr.Jit traces and
compiles a kernel per distinct launch shape; the warm-up makes every timed
render a cache hit), without reading the image back. twintrace's side
(`twintrace perf`, the render call with the pipeline already built, its
film read back) is measured by the same definition, render only.

The relMSE of each render against a reference is computed afterwards by
`twintrace diff` (run.sh does both).
"""
import json
import os
import sys
import time

import numpy as np
import drjit as dr
import mitsuba as mi

from render import write_exr

LADDER_MIN = int(os.environ.get("LADDER_MIN", "1"))
LADDER_MAX = int(os.environ.get("LADDER_MAX", "1024"))
REPS = int(os.environ.get("REPS", "5"))


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: time_to_error.py SCENE_DIR OUT_DIR")
    mi.set_variant(os.environ.get("MITSUBA_VARIANT", "cuda_ad_rgb"))
    # twintrace's plugins (plugins/ beside this file), as render.py does.
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "plugins"))
    import twintrace_plugins
    twintrace_plugins.register()
    scene_dir, out_dir = sys.argv[1:]
    os.makedirs(out_dir, exist_ok=True)
    scene = mi.load_file(os.path.join(scene_dir, "scene.xml"))
    software = f"Mitsuba {mi.__version__} ({mi.variant()}, path integrator)"
    rows = []
    spp = max(LADDER_MIN, 1)
    while spp <= LADDER_MAX:
        # Warm-up at this spp (seed outside the timed ones).
        mi.render(scene, spp=spp, seed=2**31 - spp)
        dr.sync_thread()
        times = []
        for rep in range(REPS):
            t0 = time.perf_counter()
            image = mi.render(scene, spp=spp, seed=1000 * spp + rep)
            dr.sync_thread()
            times.append(time.perf_counter() - t0)
            if rep == 0:
                rgb = np.array(image, dtype=np.float64)[:, :, :3]
                planes = {ch: rgb[:, :, c] for c, ch in enumerate("RGB")}
                write_exr(os.path.join(out_dir, f"mitsuba-{spp}.exr"), planes,
                          {"spp": spp, "software": software})
        rows.append({"spp": spp, "seconds": times, "min_s": min(times),
                     "median_s": sorted(times)[len(times) // 2]})
        print(json.dumps(rows[-1]), flush=True)
        spp *= 2
    info = {"software": software, "drjit": dr.__version__, "reps": REPS,
            "time": "mi.render + dr.sync_thread(), after a warm-up render at the same spp",
            "ladder": rows}
    with open(os.path.join(out_dir, "mitsuba-times.json"), "w") as f:
        json.dump(info, f, indent=1)


if __name__ == "__main__":
    main()
