"""Prints Mitsuba 3's tabulated conductors as its rgb variants hold them,
the rows of reference/src/loader/mitsuba/scene.rs's NAMED_CONDUCTORS.

    pip install mitsuba==3.9.1 && python3 xtask/mitsuba/named_conductors.py

Each row: the name, then eta and k of each colour channel, as
`mi.traverse` reads them back from a `conductor` of that `material`
(f32, printed at their shortest).
"""
import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
mi.set_log_level(mi.LogLevel.Error)

# Mitsuba 3's conductor documentation's table of materials (less "none").
NAMES = (
    "a-C Ag Al AlAs AlAs_palik AlSb AlSb_palik Au Be Cr CsI Cu Cu_palik "
    "Cu2O CuO d-C Hg HgTe Ir K Li MgO Mo Na_palik Nb Ni_palik Rh Se "
    "Se_palik SiC SnTe Ta Te ThF4 TiC TiN TiO2 VC V_palik VN W"
).split()


def f32(x):
    s = str(np.float32(x))
    return s if ("." in s or "e" in s) else s + ".0"


def main():
    for name in NAMES:
        p = mi.traverse(mi.load_dict({"type": "conductor", "material": name}))
        eta = ", ".join(f32(v) for v in p["eta.value"])
        k = ", ".join(f32(v) for v in p["k.value"])
        print(f'    ("{name}", [{eta}], [{k}]),')


if __name__ == "__main__":
    main()
