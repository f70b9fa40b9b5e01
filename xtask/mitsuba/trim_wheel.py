#!/usr/bin/env python3
"""Copies a Mitsuba 3 wheel without what the cuda_ad_rgb renders of
`cargo xtask mitsuba` never load (the other variants, headers, volume,
curve and unused BSDF plugins; `volpath` stays, for the absorbing
dielectrics' interior media), so that it and Dr.Jit fit in what travels
to the GPU machine. Usage: trim_wheel.py IN.whl OUT.whl"""
import re
import sys
import zipfile

DROP = re.compile(
    r"^mitsuba/("
    r"llvm_ad_.*|scalar_.*|cuda_ad_(mono|spectral).*|include/.*|data/sunsky/.*"
    r"|plugins/(volpathmis|ellipsoids|ellipsoidsmesh|bsplinecurve|linearcurve"
    r"|sunsky|timed_sunsky|sdfgrid|ptracer|principled|principledthin|cylinder|hair"
    r"|measured|measured_polarized|roughdielectric|roughplastic|plastic)\.so"
    r")$"
)

src, dst = sys.argv[1], sys.argv[2]
kept = dropped = 0
with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
    for item in zin.infolist():
        if DROP.match(item.filename):
            dropped += 1
            continue
        zout.writestr(item, zin.read(item.filename))
        kept += 1
print(f"trim_wheel: kept {kept} files, dropped {dropped}")
