"""Writes what Mitsuba 3's own BSDF plugins give on a fixed set of
inputs, for twintrace's tests to hold its models to (tests/reference/mitsuba_bsdfs.rs
regenerates the same inputs and compares).

    python3 xtask/mitsuba/bsdf_values.py CASE  [--out fixtures/mitsuba/bsdf]

CASE: conductor, dielectric, thindielectric, roughconductor,
roughdielectric, plastic, roughplastic, mask, blend, principled,
principledthin, null, anisotropic, normalmap, bumpmap.

Inputs: case i of N has its parameters from the additive sequence
frac((i + 1) * a) of the constants A below, computed in f64 with + - * /
and sqrt only (correctly rounded, so Rust computes the same bits) and
rounded to f32; the smooth models' incidence cosine is (i + 1/2) / N (wi
in the xz plane, the normal +z). Output: N records of f32 (little
endian), what each case's function says it records (three, or as many
as its docstring lists).

Needs Mitsuba 3 (`pip install mitsuba==3.9.1 numpy`); runs on the CPU
(`scalar_rgb`).
"""

import argparse
import math
import os

import mitsuba as mi
import numpy as np

N = 10000
# Irrational steps of an additive (Kronecker) sequence: fractional parts of
# powers of the plastic number and of the golden ratio's relatives.
A = [
    0.7548776662466927,
    0.5698402909980532,
    0.8191725133961645,
    0.6710436067037893,
    0.5497004779019703,
    0.3819660112501051,
    # Fractional parts of the square roots of 2, 3, 5, 7, 11, 13, 17, 19,
    # 23, 29 and 31.
    0.41421356237309515,
    0.7320508075688772,
    0.2360679774997898,
    0.6457513110645907,
    0.3166247903554,
    0.6055512754639891,
    0.12310562561766059,
    0.358898943540674,
    0.7958315233127191,
    0.38516480713450374,
    0.5677643628300215,
]


def unit(i, k):
    return ((i + 1) * A[k]) % 1.0


def surface(cos):
    """A surface interaction at normal +z with wi at incidence cosine
    `cos` (f32) in the xz plane."""
    si = mi.SurfaceInteraction3f()
    si.n = [0, 0, 1]
    si.sh_frame = mi.Frame3f(si.n)
    sin = np.float32(np.sqrt(np.float32(1.0) - cos * cos))
    si.wi = [float(sin), 0.0, float(cos)]
    return si


def conductor(i):
    """eta in [0.05, 4.05), k in [0, 8) per channel; records the sample weight per channel."""
    eta = [np.float32(0.05 + 4.0 * unit(i, c)) for c in range(3)]
    k = [np.float32(8.0 * unit(i, 3 + c)) for c in range(3)]
    cos = np.float32((i + 0.5) / N)
    bsdf = mi.load_dict(
        {
            "type": "conductor",
            "eta": {"type": "rgb", "value": [float(x) for x in eta]},
            "k": {"type": "rgb", "value": [float(x) for x in k]},
        }
    )
    si = surface(cos)
    bs, weight = bsdf.sample(mi.BSDFContext(), si, 0.5, [0.5, 0.5])
    assert bs.pdf == 1.0 and abs(bs.wo[2] - cos) < 1e-6
    return [weight[0], weight[1], weight[2]]


def dielectric(i):
    """cos in (-1, 1) (below 0: from inside), int_ior in [1, 2.6) over
    ext_ior 1. Records F, then the weight and cos of wo of a transmission
    (u = the largest f32 below 1; 0, 0 where it reflects)."""
    eta = np.float32(1.0 + 1.6 * unit(i, 0))
    cos = np.float32(2.0 * (i + 0.5) / N - 1.0)
    bsdf = mi.load_dict(
        {"type": "dielectric", "int_ior": float(eta), "ext_ior": 1.0}
    )
    si = surface(cos)
    f = mi.fresnel(float(cos), float(eta))[0]
    u = float(np.nextafter(np.float32(1.0), np.float32(0.0)))
    bs, weight = bsdf.sample(mi.BSDFContext(), si, u, [0.5, 0.5])
    if bs.wo[2] * cos < 0:
        return [f, weight[0], bs.wo[2]]
    return [f, 0.0, 0.0]


def thindielectric(i):
    """cos in (-1, 1) (below 0: from behind), int_ior in [1, 2.6) over
    ext_ior 1. Records the probability of reflection (the pdf of a
    reflection drawn at u = 0), then the cos of wo of a transmission (u =
    the largest f32 below 1) and its weight."""
    eta = np.float32(1.0 + 1.6 * unit(i, 0))
    cos = np.float32(2.0 * (i + 0.5) / N - 1.0)
    bsdf = mi.load_dict(
        {"type": "thindielectric", "int_ior": float(eta), "ext_ior": 1.0}
    )
    si = surface(cos)
    reflected, _ = bsdf.sample(mi.BSDFContext(), si, 0.0, [0.5, 0.5])
    assert reflected.wo[2] * cos > 0
    u = float(np.nextafter(np.float32(1.0), np.float32(0.0)))
    bs, weight = bsdf.sample(mi.BSDFContext(), si, u, [0.5, 0.5])
    assert bs.wo[2] * cos < 0
    return [reflected.pdf, bs.wo[2], weight[0]]


def rough_inputs(i):
    """Case i of the rough models: distribution (even i GGX, odd
    Beckmann), alpha in [0.02, 1), wi (the viewer, upper hemisphere, any
    azimuth) and wo (the light: wi reflected about a microfacet normal
    spread as the lobe is, so most pairs fall where the BSDF is not
    negligible), in f64."""
    distribution, alpha, wi, m = rough_normal(i)
    d = wi[0] * m[0] + wi[1] * m[1] + wi[2] * m[2]
    wo = tuple(2.0 * d * m[k] - wi[k] for k in range(3))
    return distribution, alpha, wi, wo


def rough_normal(i, alpha=None):
    """rough_inputs' distribution, alpha (unit 0 unless given), wi and its
    microfacet normal m."""
    if alpha is None:
        alpha = 0.02 + 0.98 * unit(i, 0)
    cos_i = unit(i, 3)
    sin_i = (1.0 - cos_i * cos_i) ** 0.5
    x, y = 2.0 * unit(i, 4) - 1.0, 2.0 * unit(i, 5) - 1.0
    r = (x * x + y * y) ** 0.5
    wi = (sin_i * x / r, sin_i * y / r, cos_i)
    t = unit(i, 6)
    tan_m = alpha * (t / (1.0 - t)) ** 0.5
    cos_m = 1.0 / (1.0 + tan_m * tan_m) ** 0.5
    sin_m = tan_m * cos_m
    x, y = 2.0 * unit(i, 7) - 1.0, 2.0 * unit(i, 8) - 1.0
    r = (x * x + y * y) ** 0.5
    m = (sin_m * x / r, sin_m * y / r, cos_m)
    return ("beckmann" if i % 2 else "ggx"), alpha, wi, m


def rough_dielectric_inputs(i):
    """Case i of the rough dielectric: rough_normal's, with int_ior eta
    in [1.05, 2.55) over ext_ior 1, wi and m mirrored below the surface
    where unit 2 < 1/2 (the viewer inside), and wo refracted through m
    where unit 11 < 1/2 (reflected past the critical angle), else
    reflected; in f64."""
    distribution, alpha, wi, m = rough_normal(i)
    eta = 1.05 + 1.5 * unit(i, 1)
    if unit(i, 2) < 0.5:
        wi = (wi[0], wi[1], -wi[2])
        m = (m[0], m[1], -m[2])
    c = wi[0] * m[0] + wi[1] * m[1] + wi[2] * m[2]
    rel = eta if wi[2] > 0.0 else 1.0 / eta
    sin2_t = (1.0 - c * c) / (rel * rel)
    if unit(i, 11) < 0.5 and sin2_t < 1.0:
        t = c / rel - (1.0 - sin2_t) ** 0.5
        wo = tuple(t * m[k] - wi[k] / rel for k in range(3))
    else:
        wo = tuple(2.0 * c * m[k] - wi[k] for k in range(3))
    return distribution, alpha, eta, wi, wo


def rough_surface(wi):
    si = mi.SurfaceInteraction3f()
    si.n = [0, 0, 1]
    si.sh_frame = mi.Frame3f(si.n)
    si.wi = [float(np.float32(c)) for c in wi]
    return si


def roughconductor(i):
    """Records 7 f32: eval and pdf at (wi, wo), then a sample drawn at u
    = (unit 9, unit 10): its wo (three), weight and pdf (weight 0: none).
    eta in [0.2, 3.2) and k in [0, 5) the same in each channel (read in
    channel 0)."""
    distribution, alpha, wi, wo = rough_inputs(i)
    eta = np.float32(0.2 + 3.0 * unit(i, 1))
    k = np.float32(5.0 * unit(i, 2))
    bsdf = mi.load_dict(
        {
            "type": "roughconductor",
            "distribution": distribution,
            "alpha": float(np.float32(alpha)),
            "eta": float(eta),
            "k": float(k),
        }
    )
    return rough_records(bsdf, wi, wo, i)


def anisotropic_inputs(i):
    """rough_inputs' alpha (as alpha_u), wi and wo, GGX always, and
    alpha_v in [0.02, 1) (unit 13)."""
    _, alpha_u, wi, wo = rough_inputs(i)
    return alpha_u, 0.02 + 0.98 * unit(i, 13), wi, wo


def anisotropic_conductor(i):
    alpha_u, alpha_v, _, _ = anisotropic_inputs(i)
    return {
        "type": "roughconductor",
        "distribution": "ggx",
        "alpha_u": float(np.float32(alpha_u)),
        "alpha_v": float(np.float32(alpha_v)),
        "eta": float(np.float32(0.2 + 3.0 * unit(i, 1))),
        "k": float(np.float32(5.0 * unit(i, 2))),
    }


def rough_records(bsdf, wi, wo, i, si=None):
    """eval and pdf at (wi, wo), then a sample drawn at u = (unit 9,
    unit 10): its wo (three), weight and pdf (weight 0: none); at
    rough_surface(wi) unless si is given."""
    if si is None:
        si = rough_surface(wi)
    ctx = mi.BSDFContext()
    wo = mi.Vector3f([float(np.float32(c)) for c in wo])
    value = bsdf.eval(ctx, si, wo)[0]
    pdf = bsdf.pdf(ctx, si, wo)
    u = [float(np.float32(unit(i, 9))), float(np.float32(unit(i, 10)))]
    bs, weight = bsdf.sample(ctx, si, 0.5, u)
    return [value, pdf, bs.wo[0], bs.wo[1], bs.wo[2], weight[0], bs.pdf]


def anisotropic(i):
    """Records 7 f32 as roughconductor's, of an anisotropic GGX
    roughconductor: alpha_u (along the frame's x, Mitsuba's sh_frame.s)
    and alpha_v (along y) from anisotropic_inputs."""
    _, _, wi, wo = anisotropic_inputs(i)
    return rough_records(mi.load_dict(anisotropic_conductor(i)), wi, wo, i)


def normal_map_texel(i):
    """Case i's normal map value (1 + m) / 2, m a unit normal tilted
    from +z by up to asin 0.85 (about 58 degrees; units 14-16)."""
    x, y = 2.0 * unit(i, 14) - 1.0, 2.0 * unit(i, 15) - 1.0
    r = (x * x + y * y) ** 0.5
    sin_t = 0.85 * unit(i, 16)
    m = (sin_t * x / r, sin_t * y / r, (1.0 - sin_t * sin_t) ** 0.5)
    return [(1.0 + c) * 0.5 for c in m]


def normalmap(i):
    """Records 7 f32 as roughconductor's, of Mitsuba's normalmap (a
    rawconstant of normal_map_texel) around anisotropic's conductor, the
    viewer below the surface where i % 5 == 4 (wi's z negated)."""
    _, _, wi, wo = anisotropic_inputs(i)
    if i % 5 == 4:
        wi = (wi[0], wi[1], -wi[2])
    bsdf = mi.load_dict(
        {
            "type": "normalmap",
            "normalmap": {
                "type": "rawconstant",
                "value": [float(np.float32(c)) for c in normal_map_texel(i)],
            },
            "bsdf": anisotropic_conductor(i),
        }
    )
    return rough_records(bsdf, wi, wo, i)


BUMP_SIZE = 4


def bump_inputs(i):
    """Case i's bump map: a BUMP_SIZE x BUMP_SIZE height image (rows from
    the top; texel t is unit 14 of case BUMP_SIZE^2 * i + t), the point's
    uv in Mitsuba's convention (v down the image; units 15 and 16, on a
    grid of 2^-16 so that twintrace's v = 1 - v is exact),
    dp_du and dp_dv (each mostly along x or y with parts along the
    others, the normal's included; units 0-5 of case N + i) and the
    scale in [0.05, 0.35) (unit 6 of case N + i), all rounded to f32."""
    f = lambda x: float(np.float32(x))  # noqa: E731
    texels = [f(unit(BUMP_SIZE * BUMP_SIZE * i + t, 14)) for t in range(BUMP_SIZE * BUMP_SIZE)]
    uv = [math.floor(unit(i, k) * 65536.0) / 65536.0 for k in (15, 16)]
    j = N + i
    dp_du = [f(0.5 + unit(j, 0)), f(0.3 * (unit(j, 1) - 0.5)), f(0.4 * (unit(j, 2) - 0.5))]
    dp_dv = [f(0.3 * (unit(j, 3) - 0.5)), f(0.5 + unit(j, 4)), f(0.4 * (unit(j, 5) - 0.5))]
    return texels, uv, dp_du, dp_dv, f(0.05 + 0.3 * unit(j, 6))


def bumpmap(i):
    """Records 7 f32 as roughconductor's, of Mitsuba's bumpmap (a raw
    bilinear bitmap of bump_inputs' height, repeated) around
    anisotropic's conductor, at bump_inputs' uv, dp_du and dp_dv, the
    viewer below the surface where i % 5 == 4 (wi's z negated)."""
    _, _, wi, wo = anisotropic_inputs(i)
    if i % 5 == 4:
        wi = (wi[0], wi[1], -wi[2])
    texels, uv, dp_du, dp_dv, scale = bump_inputs(i)
    image = np.array(texels, dtype=np.float32).reshape(BUMP_SIZE, BUMP_SIZE, 1)
    bsdf = mi.load_dict(
        {
            "type": "bumpmap",
            "scale": scale,
            "height": {"type": "bitmap", "bitmap": mi.Bitmap(image), "raw": True},
            "bsdf": anisotropic_conductor(i),
        }
    )
    si = rough_surface(wi)
    si.uv = uv
    si.dp_du = dp_du
    si.dp_dv = dp_dv
    return rough_records(bsdf, wi, wo, i, si)


def roughdielectric(i):
    """Records 7 f32: eval and pdf at (wi, wo), then a sample drawn at
    lobe u = unit 12 and u = (unit 9, unit 10): its wo (three), weight
    and pdf (weight 0: none)."""
    distribution, alpha, eta, wi, wo = rough_dielectric_inputs(i)
    bsdf = mi.load_dict(
        {
            "type": "roughdielectric",
            "distribution": distribution,
            "alpha": float(np.float32(alpha)),
            "int_ior": float(np.float32(eta)),
            "ext_ior": 1.0,
        }
    )
    si = rough_surface(wi)
    ctx = mi.BSDFContext()
    wo = mi.Vector3f([float(np.float32(c)) for c in wo])
    value = bsdf.eval(ctx, si, wo)[0]
    pdf = bsdf.pdf(ctx, si, wo)
    u = [float(np.float32(unit(i, 9))), float(np.float32(unit(i, 10)))]
    bs, weight = bsdf.sample(ctx, si, float(np.float32(unit(i, 12))), u)
    return [value, pdf, bs.wo[0], bs.wo[1], bs.wo[2], weight[0], bs.pdf]


def plastic_inputs(i):
    """Case i of the plastic: diffuse reflectance in [0, 1) per channel
    (units 0-2), int_ior in [1.05, 2.55) over ext_ior 1 (unit 3),
    nonlinear on odd i, a specular tint in [0, 1) per channel (units
    9-11) where i is a multiple of 3 (else none: white), wi (the viewer)
    at cos = unit 4 and azimuth 2 pi unit 5, wo (the light) at cos =
    sqrt(unit 6) and azimuth 2 pi unit 7; in f64."""
    diffuse = [unit(i, c) for c in range(3)]
    eta = 1.05 + 1.5 * unit(i, 3)
    tint = [unit(i, 9 + c) for c in range(3)] if i % 3 == 0 else None
    wi = hemisphere(unit(i, 4), unit(i, 5))
    wo = hemisphere(unit(i, 6) ** 0.5, unit(i, 7))
    return diffuse, eta, i % 2 == 1, tint, wi, wo


def hemisphere(cos, u):
    """The direction at cosine cos from +z, azimuth 2 pi u (the records
    carry the directions, so the test needs no trigonometry of its own)."""
    sin = (1.0 - cos * cos) ** 0.5
    phi = 2.0 * np.pi * u
    return (sin * np.cos(phi), sin * np.sin(phi), cos)


def plastic(i):
    """Records 18 f32: wi and wo as the plugin saw them (three each),
    eval (three channels) and pdf at (wi, wo), then a sample drawn at
    lobe u = unit 12 and u = (unit 8, unit 2): its wo (three), weight
    (three channels), pdf, and 1 where it is the coat's mirror (0: the
    diffuse lobe)."""
    diffuse, eta, nonlinear, tint, wi, wo = plastic_inputs(i)
    spec = plastic_spec("plastic", diffuse, eta, nonlinear, tint)
    bsdf = mi.load_dict(spec)
    u = [float(np.float32(unit(i, 8))), float(np.float32(unit(i, 2)))]
    values, bs = colour_records(bsdf, wi, wo, float(np.float32(unit(i, 12))), u)
    mirror = 1.0 if mi.has_flag(bs.sampled_type, mi.BSDFFlags.DeltaReflection) else 0.0
    return values + [mirror]


def plastic_spec(kind, diffuse, eta, nonlinear, tint):
    """A plastic's dictionary for mi.load_dict: its colours and index in
    f32, over ext_ior 1, the tint only where there is one."""
    spec = {
        "type": kind,
        "diffuse_reflectance": {"type": "rgb", "value": [float(np.float32(c)) for c in diffuse]},
        "int_ior": float(np.float32(eta)),
        "ext_ior": 1.0,
        "nonlinear": nonlinear,
    }
    if tint is not None:
        spec["specular_reflectance"] = {"type": "rgb", "value": [float(np.float32(c)) for c in tint]}
    return spec


def colour_records(bsdf, wi, wo, sample1, sample2):
    """wi and wo as the plugin sees them, eval (three channels) and pdf at
    (wi, wo), and the sample drawn at sample1 and sample2: its wo, weight
    (three channels) and pdf; 17 numbers, and the sample record."""
    si = rough_surface(wi)
    ctx = mi.BSDFContext()
    wo = mi.Vector3f([float(np.float32(c)) for c in wo])
    value = bsdf.eval(ctx, si, wo)
    pdf = bsdf.pdf(ctx, si, wo)
    bs, weight = bsdf.sample(ctx, si, sample1, sample2)
    return [
        si.wi[0], si.wi[1], si.wi[2], wo[0], wo[1], wo[2],
        value[0], value[1], value[2], pdf,
        bs.wo[0], bs.wo[1], bs.wo[2], weight[0], weight[1], weight[2], bs.pdf,
    ], bs


# The rough plastic's coats (distribution, alpha, eta) are few: twintrace
# computes a coat's tables as Mitsuba does when it loads, and the test
# computes each once.
COATS = 16


def roughplastic_inputs(i):
    """Case i of the rough plastic: coat k = i % COATS, its distribution
    (even k GGX, odd Beckmann), alpha in [0.02, 1) (unit 0 of k) and
    int_ior in [1.05, 2.55) over ext_ior 1 (unit 1 of k); rough_normal's
    wi (the viewer) and m at that alpha; a
    diffuse reflectance in [0, 1) per channel (units 2, 11, 13); nonlinear
    where i // 2 is odd; a specular tint in [0, 1) per channel (units
    14-16) where i is a multiple of 3 (else none: white); wo (the light)
    wi reflected about rough_normal's m, or, where i % 5 == 4, spread as
    the cosine (cos = sqrt(unit 9), azimuth 2 pi unit 10); in f64."""
    k = i % COATS
    alpha = 0.02 + 0.98 * unit(k, 0)
    eta = 1.05 + 1.5 * unit(k, 1)
    distribution, alpha, wi, m = rough_normal(i, alpha)
    diffuse = [unit(i, k) for k in (2, 11, 13)]
    tint = [unit(i, k) for k in (14, 15, 16)] if i % 3 == 0 else None
    if i % 5 == 4:
        wo = hemisphere(unit(i, 9) ** 0.5, unit(i, 10))
    else:
        d = wi[0] * m[0] + wi[1] * m[1] + wi[2] * m[2]
        wo = tuple(2.0 * d * m[k] - wi[k] for k in range(3))
    return distribution, alpha, eta, diffuse, (i // 2) % 2 == 1, tint, wi, wo


def roughplastic(i):
    """Records 17 f32: wi and wo as the plugin saw them (three each),
    eval (three channels) and pdf at (wi, wo), then a sample drawn at
    lobe u = unit 12 and u = (unit 9, unit 10): its wo (three), weight
    (three channels; 0: none) and pdf."""
    distribution, alpha, eta, diffuse, nonlinear, tint, wi, wo = roughplastic_inputs(i)
    spec = plastic_spec("roughplastic", diffuse, eta, nonlinear, tint)
    spec["distribution"] = distribution
    spec["alpha"] = float(np.float32(alpha))
    bsdf = mi.load_dict(spec)
    u = [float(np.float32(unit(i, 9))), float(np.float32(unit(i, 10)))]
    values, _ = colour_records(bsdf, wi, wo, float(np.float32(unit(i, 12))), u)
    return values


def mask_inputs(i):
    """Case i of the mask: a diffuse reflectance in [0, 1) per channel
    (units 0-2) under a mask of opacity unit 13 (0 where i % 10 == 0, 1
    where i % 10 == 1), the diffuse one-sided, or two-sided
    (`twosided`) where i % 3 == 2; wi (the viewer) at cos = unit 4 and
    azimuth 2 pi unit 5, below the surface where i % 4 == 3; wo (the
    light) at cos = sqrt(unit 6) and azimuth 2 pi unit 7, below where
    i % 5 == 4; in f64."""
    reflectance = [unit(i, c) for c in range(3)]
    opacity = {0: 0.0, 1: 1.0}.get(i % 10, unit(i, 13))
    wi = list(hemisphere(unit(i, 4), unit(i, 5)))
    wo = list(hemisphere(unit(i, 6) ** 0.5, unit(i, 7)))
    if i % 4 == 3:
        wi[2] = -wi[2]
    if i % 5 == 4:
        wo[2] = -wo[2]
    return reflectance, opacity, i % 3 == 2, tuple(wi), tuple(wo)


def mask(i):
    """Records 18 f32: wi and wo as the plugin saw them (three each),
    eval (three channels) and pdf at (wi, wo), then a sample drawn at
    u = unit 12 and u = (unit 8, unit 2): its wo (three), weight (three
    channels; 0: none) and pdf, and 1 where it is the mask's null lobe
    (0: the diffuse's)."""
    reflectance, opacity, two_sided, wi, wo = mask_inputs(i)
    nested = {
        "type": "diffuse",
        "reflectance": {"type": "rgb", "value": [float(np.float32(c)) for c in reflectance]},
    }
    if two_sided:
        nested = {"type": "twosided", "nested": nested}
    bsdf = mi.load_dict({"type": "mask", "opacity": float(np.float32(opacity)), "nested": nested})
    u = [float(np.float32(unit(i, 8))), float(np.float32(unit(i, 2)))]
    values, bs = colour_records(bsdf, wi, wo, float(np.float32(unit(i, 12))), u)
    null = 1.0 if mi.has_flag(bs.sampled_type, mi.BSDFFlags.Null) else 0.0
    return values + [null]


def blend_inputs(i):
    """Case i of the blend: mask_inputs' diffuse reflectance, its side
    (one-sided, or `twosided` where i % 3 == 2) and its viewer and light
    as the first BSDF and the directions; as the second a one-sided GGX
    roughconductor of alpha in [0.05, 1) (unit 14), eta in [0.2, 3.2)
    (unit 15) and k in [0, 5) (unit 16); the second's weight unit 11 (0
    where i % 10 == 0, 1 where i % 10 == 1); in f64."""
    reflectance, _, two_sided, wi, wo = mask_inputs(i)
    weight = {0: 0.0, 1: 1.0}.get(i % 10, unit(i, 11))
    alpha = 0.05 + 0.95 * unit(i, 14)
    eta = 0.2 + 3.0 * unit(i, 15)
    k = 5.0 * unit(i, 16)
    return reflectance, two_sided, weight, alpha, eta, k, wi, wo


def blend(i):
    """Records 17 f32: wi and wo as the plugin saw them (three each),
    eval (three channels) and pdf at (wi, wo), then a sample drawn at
    u = unit 12 and u = (unit 8, unit 2): its wo (three), weight (three
    channels; 0: none) and pdf (the drawn BSDF's own, as Mitsuba's
    blendbsdf gives it)."""
    reflectance, two_sided, weight, alpha, eta, k, wi, wo = blend_inputs(i)
    first = {
        "type": "diffuse",
        "reflectance": {"type": "rgb", "value": [float(np.float32(c)) for c in reflectance]},
    }
    if two_sided:
        first = {"type": "twosided", "nested": first}
    second = {
        "type": "roughconductor",
        "distribution": "ggx",
        "alpha": float(np.float32(alpha)),
        "eta": float(np.float32(eta)),
        "k": float(np.float32(k)),
    }
    # The nested BSDFs in the order of their names, whichever order the
    # plugin reads them in.
    bsdf = mi.load_dict(
        {"type": "blendbsdf", "weight": float(np.float32(weight)), "a": first, "b": second}
    )
    u = [float(np.float32(unit(i, 8))), float(np.float32(unit(i, 2)))]
    values, _ = colour_records(bsdf, wi, wo, float(np.float32(unit(i, 12))), u)
    return values


# The principled cases' second draw of units: index i + SHIFT.
SHIFT = 10007


def principled_directions(i, roughness, through):
    """The principled cases' viewer wi and light wo, in f64: wi at cos =
    unit 15 and azimuth 2 pi unit 16, below the surface where i % 4 == 3;
    wo, where i % 3 == 0, wi reflected about a normal of tan = roughness^2
    sqrt(t / (1 - t)), t = unit 0 of i + SHIFT, azimuth 2 pi unit 1 of
    i + SHIFT (mirrored through the surface where `through`); else at cos
    = sqrt(unit 2 of i + SHIFT) and azimuth 2 pi unit 3 of i + SHIFT,
    below where i % 3 == 1."""
    j = i + SHIFT
    wi = list(hemisphere(unit(i, 15), unit(i, 16)))
    if i % 4 == 3:
        wi[2] = -wi[2]
    if i % 3 == 0:
        r2 = roughness ** 2
        t = unit(j, 0)
        tan_m = r2 * (t / (1.0 - t)) ** 0.5
        cos_m = 1.0 / (1.0 + tan_m * tan_m) ** 0.5
        m = hemisphere(cos_m, unit(j, 1))
        if wi[2] < 0.0:
            m = tuple(-c for c in m)
        d = sum(wi[k] * m[k] for k in range(3))
        wo = [2.0 * d * m[k] - wi[k] for k in range(3)]
        if through:
            wo[2] = -wo[2]
    else:
        wo = list(hemisphere(unit(j, 2) ** 0.5, unit(j, 3)))
        if i % 3 == 1:
            wo[2] = -wo[2]
    return tuple(wi), tuple(wo)


def principled_inputs(i):
    """Case i of the principled BSDF: its parameters (a dict of Mitsuba's
    names; a lobe left out is off) and the viewer wi and light wo, in f64.
    base_color units 0-2; roughness 0.05 + 0.95 unit 3; anisotropic unit 4
    where i % 2 == 1; metallic unit 5 where i % 3 != 0; spec_trans unit 6
    where i % 4 is 1 or 2 (0 where i % 8 == 1: the lobe given, its value
    0); clearcoat unit 7 and clearcoat_gloss unit 8 where i % 5 is 0, 2 or
    3; sheen unit 9 where i % 2 == 0; sheen_tint unit 10 where i % 3 == 1;
    flatness unit 11 where i % 6 < 3; spec_tint unit 12 where i % 7 < 4;
    eta 0.6 + 1.6 unit 13 where i % 5 == 4, else specular unit 14. wi at
    cos = unit 15 and azimuth 2 pi unit 16, below the surface where
    i % 4 == 3. wo: where i % 3 == 0, wi reflected about a normal of
    tan = roughness^2 sqrt(t / (1 - t)), t = unit 0 of i + SHIFT, azimuth
    2 pi unit 1 of i + SHIFT; else at cos = sqrt(unit 2 of i + SHIFT) and
    azimuth 2 pi unit 3 of i + SHIFT, below where i % 3 == 1."""
    params = {
        "base_color": [unit(i, c) for c in range(3)],
        "roughness": 0.05 + 0.95 * unit(i, 3),
    }
    if i % 2 == 1:
        params["anisotropic"] = unit(i, 4)
    if i % 3 != 0:
        params["metallic"] = unit(i, 5)
    if i % 4 in (1, 2):
        params["spec_trans"] = 0.0 if i % 8 == 1 else unit(i, 6)
    if i % 5 in (0, 2, 3):
        params["clearcoat"] = unit(i, 7)
        params["clearcoat_gloss"] = unit(i, 8)
    if i % 2 == 0:
        params["sheen"] = unit(i, 9)
    if i % 3 == 1:
        params["sheen_tint"] = unit(i, 10)
    if i % 6 < 3:
        params["flatness"] = unit(i, 11)
    if i % 7 < 4:
        params["spec_tint"] = unit(i, 12)
    if i % 5 == 4:
        params["eta"] = 0.6 + 1.6 * unit(i, 13)
    else:
        params["specular"] = unit(i, 14)
    return (params,) + principled_directions(i, params["roughness"], False)


def principledthin_inputs(i):
    """Case i of the thin principled BSDF: its parameters (a dict of
    Mitsuba's names; a lobe left out is off) and the viewer wi and light
    wo, in f64. base_color units 0-2; roughness 0.05 + 0.95 unit 3;
    anisotropic unit 4 where i % 2 == 1; spec_trans unit 6 where i % 4 is
    1, 2 or 3 (0 where i % 8 == 1: the lobe given, its value 0);
    diff_trans 2 unit 5 where i % 3 != 0 (Mitsuba's range, 0 to 2); sheen
    unit 9 where i % 2 == 0; sheen_tint unit 10 where i % 3 == 1; flatness
    unit 11 where i % 6 < 3; spec_tint unit 12 where i % 7 < 4; eta 0.8 +
    1.7 unit 13. wi at cos = unit 15 and azimuth 2 pi unit 16, below the
    surface where i % 4 == 3. wo: where i % 3 == 0, wi reflected about a
    normal of tan = roughness^2 sqrt(t / (1 - t)), t = unit 0 of i +
    SHIFT, azimuth 2 pi unit 1 of i + SHIFT (mirrored through the surface,
    the thin sheet's transmission, where i % 6 == 3); else at cos =
    sqrt(unit 2 of i + SHIFT) and azimuth 2 pi unit 3 of i + SHIFT, below
    where i % 3 == 1."""
    params = {
        "base_color": [unit(i, c) for c in range(3)],
        "roughness": 0.05 + 0.95 * unit(i, 3),
    }
    if i % 2 == 1:
        params["anisotropic"] = unit(i, 4)
    if i % 4 in (1, 2, 3):
        params["spec_trans"] = 0.0 if i % 8 == 1 else unit(i, 6)
    if i % 3 != 0:
        params["diff_trans"] = 2.0 * unit(i, 5)
    if i % 2 == 0:
        params["sheen"] = unit(i, 9)
    if i % 3 == 1:
        params["sheen_tint"] = unit(i, 10)
    if i % 6 < 3:
        params["flatness"] = unit(i, 11)
    if i % 7 < 4:
        params["spec_tint"] = unit(i, 12)
    params["eta"] = 0.8 + 1.7 * unit(i, 13)
    return (params,) + principled_directions(i, params["roughness"], i % 6 == 3)


def principled_plugin(kind, params):
    spec = {"type": kind}
    for name, v in params.items():
        if name == "base_color":
            spec[name] = {"type": "rgb", "value": [float(np.float32(c)) for c in v]}
        else:
            spec[name] = float(np.float32(v))
    return mi.load_dict(spec)


def principled(i):
    """Records 17 f32: wi and wo as the plugin saw them (three each),
    eval (three channels) and pdf at (wi, wo), then a sample drawn at
    lobe u = unit 4 of i + SHIFT and u = (unit 5, unit 6 of i + SHIFT):
    its wo (three), weight (three channels; 0: none) and pdf."""
    params, wi, wo = principled_inputs(i)
    bsdf = principled_plugin("principled", params)
    j = i + SHIFT
    u = [float(np.float32(unit(j, 5))), float(np.float32(unit(j, 6)))]
    values, _ = colour_records(bsdf, wi, wo, float(np.float32(unit(j, 4))), u)
    return values


def principledthin(i):
    """Records 17 f32, as principled's: wi and wo (three each), eval
    (three) and pdf, then a sample drawn at lobe u = unit 4 of i + SHIFT
    and u = (unit 5, unit 6 of i + SHIFT): its wo (three), weight (three;
    0: none) and pdf."""
    params, wi, wo = principledthin_inputs(i)
    bsdf = principled_plugin("principledthin", params)
    j = i + SHIFT
    u = [float(np.float32(unit(j, 5))), float(np.float32(unit(j, 6)))]
    values, _ = colour_records(bsdf, wi, wo, float(np.float32(unit(j, 4))), u)
    return values


def null(i):
    """Records 17 f32, as principled's, of Mitsuba's `null`: wi at cos =
    unit 15 and azimuth 2 pi unit 16 (below the surface where i is odd),
    wo at cos = sqrt(unit 2 of i + SHIFT) and azimuth 2 pi unit 3 of i +
    SHIFT (below where i % 3 == 1, the other way where i % 3 == 2: -wi);
    eval and pdf there, and the sample at lobe u = unit 4 of i + SHIFT and
    u = (unit 5, unit 6 of i + SHIFT)."""
    j = i + SHIFT
    wi = list(hemisphere(unit(i, 15), unit(i, 16)))
    if i % 2 == 1:
        wi[2] = -wi[2]
    if i % 3 == 2:
        wo = tuple(-c for c in wi)
    else:
        wo = list(hemisphere(unit(j, 2) ** 0.5, unit(j, 3)))
        if i % 3 == 1:
            wo[2] = -wo[2]
        wo = tuple(wo)
    bsdf = mi.load_dict({"type": "null"})
    u = [float(np.float32(unit(j, 5))), float(np.float32(unit(j, 6)))]
    values, _ = colour_records(bsdf, tuple(wi), wo, float(np.float32(unit(j, 4))), u)
    return values


CASES = {
    "null": null,
    "principled": principled,
    "principledthin": principledthin,
    "blend": blend,
    "mask": mask,
    "conductor": conductor,
    "dielectric": dielectric,
    "thindielectric": thindielectric,
    "roughconductor": roughconductor,
    "roughdielectric": roughdielectric,
    "plastic": plastic,
    "roughplastic": roughplastic,
    "anisotropic": anisotropic,
    "normalmap": normalmap,
    "bumpmap": bumpmap,
}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("case", choices=sorted(CASES))
    parser.add_argument("--out", default="fixtures/mitsuba/bsdf")
    args = parser.parse_args()
    mi.set_variant("scalar_rgb")
    values = np.array([CASES[args.case](i) for i in range(N)], dtype="<f4")
    os.makedirs(args.out, exist_ok=True)
    path = os.path.join(args.out, f"{args.case}.f32")
    values.tofile(path)
    with open(os.path.join(args.out, f"{args.case}.provenance.txt"), "w") as f:
        f.write(
            f"{N} records of {values.shape[1]} f32 ({' '.join(CASES[args.case].__doc__.split())}): Mitsuba {mi.__version__} ({mi.variant()}) plugin "
            f"'{args.case}', written by xtask/mitsuba/bsdf_values.py {args.case}\n"
        )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
