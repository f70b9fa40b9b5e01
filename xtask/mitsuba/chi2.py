#!/usr/bin/env python3
"""Checks the twintrace plugins (plugins/twintrace_plugins.py) with
Mitsuba 3's own tests, and prints one line per check and a summary.

- Sampling against the density: Mitsuba's `ChiSquareTest` with its
  `BSDFAdapter` (as Mitsuba's test suite checks its BSDFs), over the
  sphere of directions, for `tt_ggx` (with and without a clear coat) and
  `tt_fuzzy_metal` at several incidences; significance 0.01 each (Šidák
  over the cases is left to the reader: the count of cases is printed).
- Weight against eval/pdf: the sampled weight equals eval(wo)/pdf(wo) at
  the sampled direction (relative 1e-3, f32 arithmetic in two orders).
- `tt_dielectric` (delta lobes, which the chi-square test cannot see):
  the share of reflections against Schlick's R by Pearson's chi-square
  over the two outcomes (1 degree of freedom), Snell's law of the
  refracted directions, and total internal reflection past the critical
  angle; under shading normals, at the hits of a million rays on a
  faceted sphere (and their second hits), every sampled direction equals
  the reference's formula.
- `tt_checker`: equals the formula of reference/src/texture.rs at random
  points.
- `tt_image`: with one wrap mode for both axes it equals Mitsuba's own
  `bitmap` (v flipped, texel centres at half-integers) at random uv for
  each mode and filter: two implementations of one lookup; with two modes
  each axis equals the one-mode lookup of its mode.
- `tt_alpha`: MASK and BLEND opacities from their formulas.
- `tt_normalmap`: a flat texel leaves `tt_facing`'s frame; a tilted one
  tilts the normal toward the tangent and bitangent as the formula says.
- `tt_facing`: around `tt_diffuse`, its samples and evaluations lie on
  the side the reference's facing normal gives, for geometric normals on
  either side of the shading frame and views from either side.

Then the checks are shown to fail: each of five deliberate defects,
patched into the plugins' module for the time of its checks, must fail at
least one of them (the GGX pdf without its coat term, the fuzzy metal's
density normalized by fuzz^2, Schlick's fifth power as a fourth, the
checker's sign test inverted, the dielectric's side taken from the
shading normal alone).

Needs a vectorized variant: MITSUBA_VARIANT (default cuda_ad_rgb; on a CPU
llvm_ad_rgb with DRJIT_LIBLLVM_PATH naming libLLVM 16 or newer).
Exit status 1 when any check fails.
"""
import math
import os
import sys

import drjit as dr
import mitsuba as mi

VARIANT = os.environ.get("MITSUBA_VARIANT", "cuda_ad_rgb")
if VARIANT.startswith("scalar"):
    sys.exit(f"chi2.py: MITSUBA_VARIANT={VARIANT}: the checks need a vectorized variant "
             "(cuda_ad_rgb, llvm_ad_rgb)")
mi.set_variant(VARIANT)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "plugins"))
import twintrace_plugins  # noqa: E402

twintrace_plugins.register()
from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain  # noqa: E402

ALPHA = 0.01
failures = []
count = 0


def report(name, ok, detail):
    global count
    count += 1
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {detail}", flush=True)
    if not ok:
        failures.append(name)


def incidences():
    for theta_deg in (0.0, 30.0, 60.0, 80.0):
        t = math.radians(theta_deg)
        yield theta_deg, [math.sin(t), 0.0, math.cos(t)]


def ggx_dict(metallic, roughness, coat=None):
    d = {"type": "tt_ggx", "base_color": {"type": "rgb", "value": [0.9, 0.5, 0.2]},
         "metallic": metallic, "roughness": roughness}
    if coat:
        d["clearcoat"], d["clearcoat_roughness"] = coat
    return d


def fuzzy_dict(fuzz):
    return {"type": "tt_fuzzy_metal", "albedo": {"type": "rgb", "value": [0.8, 0.6, 0.2]},
            "fuzz": fuzz}


def chi2_case(name, d, wi):
    sample, pdf = BSDFAdapter(d["type"], d, wi=wi)
    test = ChiSquareTest(domain=SphericalDomain(), sample_func=sample, pdf_func=pdf,
                         sample_dim=3, res=201, ires=32)
    ok = test.run(significance_level=ALPHA, quiet=True)
    report(f"chi2 {name} wi={wi[0]:.3f},{wi[2]:.3f}", ok, test.messages.strip().splitlines()[-1]
           if test.messages else "")


def weight_case(name, d, wi, n=100_000):
    bsdf = mi.load_dict(d)
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(wi)
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(7, n)
    ctx = mi.BSDFContext()
    bs, weight = bsdf.sample(ctx, si, sampler.next_1d(), sampler.next_2d())
    value, pdf = bsdf.eval_pdf(ctx, si, bs.wo)
    valid = dr.all(weight > 0.0) & (pdf > 0.0)
    expect = value / dr.select(valid, pdf, 1.0)
    err = dr.max(dr.abs(weight - expect) / dr.maximum(dr.abs(expect), 1e-6))
    worst = scalar(dr.max(dr.select(valid, err, 0.0)))
    # The pdf the sample reports equals pdf() at its direction.
    perr = dr.select(valid, dr.abs(bs.pdf - pdf) / dr.maximum(pdf, 1e-6), 0.0)
    pworst = scalar(dr.max(perr))
    n_valid = int(scalar(dr.count(valid)))
    ok = worst < 1e-3 and pworst < 1e-3 and n_valid > 0
    report(f"weight {name} wi={wi[0]:.3f},{wi[2]:.3f}", ok,
           f"max |w - eval/pdf|/|eval/pdf| = {worst:.2e}, max pdf error {pworst:.2e}, {n_valid} of {n} scattered")


def scalar(x):
    return float(x[0]) if dr.is_array_v(x) else float(x)


def dielectric_cases(n=400_000):
    bsdf = mi.load_dict({"type": "tt_dielectric", "ior": 1.5})
    ctx = mi.BSDFContext()
    for inside in (False, True):
        eta = 1.5 if inside else 1.0 / 1.5
        for theta_deg in (0.0, 20.0, 40.0, 60.0, 85.0):
            t = math.radians(theta_deg)
            wi = [math.sin(t), 0.0, -math.cos(t) if inside else math.cos(t)]
            si = dr.zeros(mi.SurfaceInteraction3f, n)
            si.wi = mi.Vector3f(wi)
            sampler = mi.load_dict({"type": "independent"})
            sampler.seed(11, n)
            bs, weight = bsdf.sample(ctx, si, sampler.next_1d(), sampler.next_2d())
            reflected = dr.sign(bs.wo.z) == dr.sign(mi.Float(wi[2]))
            k = scalar(dr.count(reflected))
            cos_i = math.cos(t)
            sin2_t = eta * eta * (1.0 - cos_i * cos_i)
            side = "inside" if inside else "outside"
            if sin2_t >= 1.0:
                report(f"dielectric TIR {side} {theta_deg}°", k == n, f"{int(k)} of {n} reflected")
                continue
            r0 = ((1.0 - eta) / (1.0 + eta)) ** 2
            r = r0 + (1.0 - r0) * (1.0 - cos_i) ** 5
            e1, e2 = n * r, n * (1.0 - r)
            x2 = (k - e1) ** 2 / e1 + ((n - k) - e2) ** 2 / e2
            # 1 degree of freedom: P(X > x2) = erfc(sqrt(x2 / 2)).
            p = math.erfc(math.sqrt(x2 / 2.0))
            report(f"dielectric Schlick share {side} {theta_deg}°", p > ALPHA,
                   f"{int(k)} of {n} reflected, R = {r:.5f}, chi2 = {x2:.3f}, p = {p:.3f}")
            # Snell's law: sin θt = eta sin θi for the refracted ones.
            sin_t = dr.sqrt(dr.square(bs.wo.x) + dr.square(bs.wo.y))
            snell = dr.select(reflected, 0.0, dr.abs(sin_t - eta * math.sin(t)))
            w_ok = dr.all(weight == 1.0)
            worst = scalar(dr.max(snell))
            report(f"dielectric Snell {side} {theta_deg}°", worst < 1e-5 and scalar(dr.count(w_ok)) == n,
                   f"max |sin θt − η sin θi| = {worst:.1e}, weights all 1")


def checker_case(n=100_000):
    tex = mi.load_dict({"type": "tt_checker", "scale": 3.0,
                        "even": {"type": "rgb", "value": [0.1, 0.2, 0.3]},
                        "odd": {"type": "rgb", "value": [0.9, 0.8, 0.7]}})
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(3, n)
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.p = mi.Point3f(10 * sampler.next_1d() - 5, 10 * sampler.next_1d() - 5, 10 * sampler.next_1d() - 5)
    got = tex.eval(si)
    odd = dr.sin(3.0 * si.p.x) * dr.sin(3.0 * si.p.y) * dr.sin(3.0 * si.p.z) < 0.0
    expect = dr.select(odd, mi.Color3f(0.9, 0.8, 0.7), mi.Color3f(0.1, 0.2, 0.3))
    same = dr.all(got == expect)
    k = scalar(dr.count(same))
    n_odd = scalar(dr.count(odd))
    report("checker against the formula", k == n and 0 < n_odd < n,
           f"{int(k)} of {n} points equal, {int(n_odd)} odd")


def dielectric_facing_case(n=100_000):
    # Under shading normals the side is the geometric normal's: seen from
    # above the shading frame but behind the geometric normal (ng = -z),
    # the glass is entered from inside (eta = 1.5) about the facing normal
    # +z, so at 60° every ray reflects (sin θt = 1.5 · 0.866 > 1); without
    # the flag it would refract from outside.
    bsdf = mi.load_dict({"type": "tt_dielectric", "ior": 1.5, "facing": True})
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    si.n = mi.Normal3f(0, 0, -1)
    t = math.radians(60.0)
    si.wi = mi.Vector3f(math.sin(t), 0.0, math.cos(t))
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(13, n)
    bs, _ = bsdf.sample(mi.BSDFContext(), si, sampler.next_1d(), sampler.next_2d())
    k = scalar(dr.count(bs.wo.z > 0.0))
    report("dielectric facing: inside by the geometric normal", k == n, f"{int(k)} of {n} reflected")


def uv_sphere_mesh(bsdf):
    """examples/gen_fixtures.rs's glTF sphere (32 x 16, radius 1, vertex
    normals = positions; offset_bias.py's) at the origin, with `bsdf`."""
    from offset_bias import uv_sphere
    pos, faces = uv_sphere()
    mesh = mi.Mesh("sphere", len(pos), len(faces), has_vertex_normals=True)
    params = mi.traverse(mesh)
    params["vertex_positions"] = dr.ravel(mi.Point3f(pos[:, 0], pos[:, 1], pos[:, 2]))
    params["vertex_normals"] = dr.ravel(mi.Normal3f(pos[:, 0], pos[:, 1], pos[:, 2]))
    params["faces"] = dr.ravel(mi.Vector3u(faces[:, 0], faces[:, 1], faces[:, 2]))
    params.update()
    mesh.set_bsdf(mi.load_dict(bsdf))
    return mi.load_dict({"type": "scene", "sphere": mesh})


def dielectric_mesh_case(n=1_000_000):
    # `tt_dielectric` with `facing` on real hits of a faceted sphere under
    # interpolated normals (gltf-materials' glass): rays from 5.6 away at
    # points of the disc the sphere covers (half of them at its rim, where
    # the view can lie below the shading normal), then the second hit of
    # each sampled direction. Every sampled direction equals the
    # reference's `scatter` of a dielectric (reference/src/material.rs),
    # written here in world space from the hit's normals: the shading
    # normal put on the geometric side, flipped toward the ray by the
    # geometric normal, Schlick's R of the incident cosine against the
    # lobe number, Snell's refraction or the mirror.
    scene = uv_sphere_mesh({"type": "tt_dielectric", "ior": 1.5, "facing": True})
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(17, n)
    u = sampler.next_2d()
    radius = dr.select(u.x < 0.5, 0.9 + 0.2 * u.x, 1.1 * dr.sqrt(2.0 * u.x - 1.0))
    s, c = dr.sincos(2.0 * math.pi * u.y)
    origin = mi.Point3f(0.0, 0.0, 5.6)
    ray = mi.Ray3f(origin, dr.normalize(mi.Point3f(radius * c, radius * s, 0.0) - origin))
    ctx = mi.BSDFContext()
    worst, hits, below = 0.0, 0, 0
    for _ in range(2):
        si = scene.ray_intersect(ray)
        hit = si.is_valid()
        lobe = sampler.next_1d()
        bs, weight = si.bsdf(ray).sample(ctx, si, lobe, sampler.next_2d(), hit)
        got = si.to_world(bs.wo)
        d = ray.d
        ng = si.n
        ns = dr.select(dr.dot(si.sh_frame.n, ng) < 0.0, -1.0, 1.0) * si.sh_frame.n
        front = dr.dot(d, ng) < 0.0
        nf = dr.select(front, ns, -ns)
        eta = dr.select(front, 1.0 / 1.5, 1.5)
        cos_i = dr.minimum(dr.dot(-d, nf), 1.0)
        sin2_t = eta * eta * dr.maximum(1.0 - cos_i * cos_i, 0.0)
        cos_t = dr.sqrt(dr.maximum(1.0 - sin2_t, 0.0))
        refracted = dr.normalize(eta * d + (eta * cos_i - cos_t) * nf)
        reflected = d - 2.0 * dr.dot(d, nf) * nf
        r0 = dr.square((1.0 - eta) / (1.0 + eta))
        schlick = r0 + (1.0 - r0) * dr.power(1.0 - cos_i, 5)
        refract = (sin2_t < 1.0) & (schlick <= lobe)
        want = dr.select(refract, refracted, reflected)
        err = dr.select(hit, dr.norm(got - want) + dr.abs(weight[0] - 1.0), 0.0)
        worst = max(worst, scalar(dr.max(err)))
        hits += int(scalar(dr.count(hit)))
        below += int(scalar(dr.count(hit & (cos_i < 0.0))))
        ray = si.spawn_ray(got)
    # 1e-5: one formula in f32 computed two ways (5.5e-7 measured); a
    # wrong side or lobe is off by ~1 (the mutant: 0.87).
    report("dielectric facing on a faceted sphere's hits", worst < 1e-5 and below > 0,
           f"{hits} hits ({below} viewed below the facing shading normal), "
           f"max |direction - reference's| + |weight - 1| = {worst:.1e}")


def facing_cases(n=10_000):
    bsdf = mi.load_dict({"type": "tt_facing", "inner": {
        "type": "tt_diffuse", "reflectance": {"type": "rgb", "value": [0.5, 0.5, 0.5]}}})
    ctx = mi.BSDFContext()
    s2 = math.sqrt(0.5)
    # (geometric normal in the shading frame, wi, the side the reference's
    # facing normal is on: (front ? 1 : -1) * (n.ng < 0 ? -1 : 1)).
    for ng, wi, want in [
        ([0, 0, 1], [0.3, 0, 0.954], 1),
        ([0, 0, 1], [0.3, 0, -0.954], -1),
        ([0, 0, -1], [0.3, 0, 0.954], 1),
        ([0.8, 0, 0.6], [-0.9, 0, 0.436], -1),
        ([0.8, 0, 0.6], [0.9, 0, -0.436], 1),
        ([-s2, 0, -s2], [0.6, 0, 0.8], 1),
        ([-s2, 0, -s2], [-0.6, 0, -0.8], -1),
    ]:
        si = dr.zeros(mi.SurfaceInteraction3f, n)
        si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
        si.n = mi.Normal3f(ng)
        si.wi = dr.normalize(mi.Vector3f(wi))
        sampler = mi.load_dict({"type": "independent"})
        sampler.seed(5, n)
        bs, weight = bsdf.sample(ctx, si, sampler.next_1d(), sampler.next_2d())
        on_side = scalar(dr.count(bs.wo.z * want > 0.0))
        up = bsdf.eval(ctx, si, mi.Vector3f(0.0, 0.0, float(want)))[0]
        down = bsdf.eval(ctx, si, mi.Vector3f(0.0, 0.0, -float(want)))[0]
        ok = on_side == n and scalar(up) > 0.0 and scalar(down) == 0.0
        report(f"facing ng={ng} wi={wi}", ok,
               f"{int(on_side)} of {n} samples on side {want}, eval there {scalar(up):.4f}, opposite {scalar(down)}")


def image_cases(n=20_000):
    import numpy as np
    import tempfile
    rng = np.random.default_rng(4)
    texels = rng.uniform(0.0, 1.0, (5, 7, 3)).astype(np.float32)
    folder = tempfile.mkdtemp()
    path = os.path.join(folder, "texels.exr")
    mi.Bitmap(texels).write(path)
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(9, n)
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.uv = mi.Point2f(6.0 * sampler.next_1d() - 3.0, 6.0 * sampler.next_1d() - 3.0)
    flip = mi.ScalarTransform4f([[1, 0, 0, 0], [0, -1, 0, 1], [0, 0, 1, 0], [0, 0, 0, 1]])

    def ours(wu, wv, nearest):
        return mi.load_dict({"type": "tt_image", "filename": path, "wrap_u": wu, "wrap_v": wv,
                             "nearest": nearest}).eval(si)

    for mode in ("repeat", "clamp", "mirror"):
        for nearest in (False, True):
            theirs = mi.load_dict({"type": "bitmap", "filename": path, "raw": True, "accel": False,
                                   "wrap_mode": mode, "to_uv": flip,
                                   "filter_type": "nearest" if nearest else "bilinear"}).eval(si)
            err = scalar(dr.max(dr.max(dr.abs(ours(mode, mode, nearest) - theirs))))
            # Nearest lookups may pick the other texel where uv rounds onto
            # a texel edge: counted, at most 0.1 %.
            off = scalar(dr.count(dr.max(dr.abs(ours(mode, mode, nearest) - theirs)) > 1e-5))
            ok = (off <= n * 1e-3) if nearest else err < 1e-5
            report(f"tt_image = bitmap, {mode}, {'nearest' if nearest else 'bilinear'}", ok,
                   f"max difference {err:.1e}, {int(off)} of {n} lookups differ")
    # Two modes: u behaves as the u-mode's image, v as the v-mode's, seen
    # where the other coordinate stays inside [0, 1].
    si.uv = mi.Point2f(si.uv.x, 0.5 + 0.1 * dr.sin(si.uv.y))
    mixed = ours("mirror", "clamp", False)
    err = scalar(dr.max(dr.max(dr.abs(mixed - ours("mirror", "mirror", False)))))
    report("tt_image two modes: u mirrored", err < 1e-6, f"max difference {err:.1e}")


def alpha_cases(n=10_000):
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(12, n)
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.p = mi.Point3f(sampler.next_1d(), sampler.next_1d(), sampler.next_1d())
    # A spatially varying alpha: a checker of 0.3 and 0.7.
    for cutoff in (-1.0, 0.5):
        tex = mi.load_dict({"type": "tt_alpha", "cutoff": cutoff, "alpha": {
            "type": "tt_checker", "scale": 3.0,
            "even": {"type": "rgb", "value": [0.3, 0.0, 0.0]},
            "odd": {"type": "rgb", "value": [0.7, 0.0, 0.0]}}})
        odd = dr.sin(3.0 * si.p.x) * dr.sin(3.0 * si.p.y) * dr.sin(3.0 * si.p.z) < 0.0
        a = dr.select(odd, 0.7, 0.3)
        want = dr.select(a >= cutoff, 1.0, 0.0) if cutoff >= 0.0 else a
        got = tex.eval_1(si)
        err = scalar(dr.max(dr.abs(got - want)))
        report(f"tt_alpha {'MASK 0.5' if cutoff >= 0 else 'BLEND'}", err < 1e-6,
               f"max difference {err:.1e}")


class _Constant(mi.Texture):
    """A constant of any sign (Mitsuba's `rgb` refuses values outside
    [0, 1] where it expects a reflectance), as a mesh attribute may be."""

    def __init__(self, props):
        mi.Texture.__init__(self, props)
        self.value = mi.Color3f(props.get("x", 0.0), props.get("y", 0.0), props.get("z", 0.0))

    def eval(self, si, active=True):
        return self.value


mi.register_texture("chi2_constant", lambda props: _Constant(props))


def normalmap_cases(n=1000):
    def make(texel):
        return mi.load_dict({
            "type": "tt_normalmap", "scale": 0.5,
            "normal_map": {"type": "rgb", "value": texel},
            "tangent": {"type": "rgb", "value": [1.0, 0.0, 0.3]},
            "tsign": {"type": "chi2_constant", "x": -1.0, "y": -1.0, "z": -1.0},
            "inner": {"type": "tt_diffuse", "reflectance": {"type": "rgb", "value": [0.5, 0.5, 0.5]}}})
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    si.n = mi.Normal3f(0, 0, 1)
    si.wi = mi.Vector3f(0.0, 0.6, 0.8)
    f = make([0.5, 0.5, 1.0]).frame(si)
    err = scalar(dr.max(dr.abs(f.n - mi.Vector3f(0, 0, 1))))
    report("tt_normalmap flat texel keeps the normal", err < 1e-6, f"max deviation {err:.1e}")
    # Texel toward +x and +y: m = ((2c-1) * 0.5 for x, y; 2c-1 for z);
    # t = x (orthogonalized), b = -(n x t) = -y (w < 0).
    c = [0.8, 0.7, 0.9]
    m = [(2 * c[0] - 1) * 0.5, (2 * c[1] - 1) * 0.5, 2 * c[2] - 1]
    want = mi.Vector3f(m[0], -m[1], m[2])
    want = want / dr.norm(want)
    f = make(c).frame(si)
    err = scalar(dr.max(dr.abs(f.n - want)))
    report("tt_normalmap tilted texel", err < 1e-6, f"max deviation {err:.1e}")
    # Seen from below the geometric surface: the mapped normal flipped.
    si.wi = mi.Vector3f(0.0, 0.6, -0.8)
    f = make(c).frame(si)
    err = scalar(dr.max(dr.abs(f.n + want)))
    report("tt_normalmap from behind", err < 1e-6, f"max deviation {err:.1e}")


def mutant_cases():
    """Each defect patched in, its checks run: at least one must fail."""
    global failures, count
    p = twintrace_plugins
    GgxLobes = p.GgxLobes

    def coatless_pdf(self, wo, wi):
        valid = (wo.z > 0.0) & (wi.z > 0.0)
        h = dr.normalize(wo + wi)
        spec_pdf = p.ggx_visible_normal_pdf(wo, h, self.alpha) / (4.0 * dr.dot(wo, h))
        q = self.specular_probability
        return dr.select(valid, q * spec_pdf + (1.0 - q) * wi.z * (1.0 / p.PI), 0.0)

    fuzzy_pdf = p.fuzzy_pdf
    schlick = p.schlick_reflectance
    checker_odd = p.TTChecker._odd
    facing_sign = p.facing_sign
    wi = [math.sin(math.radians(30.0)), 0.0, math.cos(math.radians(30.0))]
    mutants = [
        ("GgxLobes.pdf without the coat", lambda: setattr(GgxLobes, "pdf", coatless_pdf),
         lambda: setattr(GgxLobes, "pdf", GgxLobes.__dict__["pdf"]),
         lambda: chi2_case("ggx coat 1/0.6 (mutant)", ggx_dict(1.0, 0.3, (1.0, 0.6)), wi)),
        ("fuzzy pdf / fuzz^2", lambda: setattr(p, "fuzzy_pdf", lambda w, r, f: fuzzy_pdf(w, r, f) * f),
         lambda: setattr(p, "fuzzy_pdf", fuzzy_pdf),
         lambda: chi2_case("fuzzy metal 0.6 (mutant)", fuzzy_dict(0.6), wi)),
        ("Schlick's fourth power", lambda: setattr(
            p, "schlick_reflectance",
            lambda c, e: schlick(c, e) + (1.0 - dr.square((1.0 - e) / (1.0 + e)))
            * dr.square(dr.square(1.0 - c)) * c),
         lambda: setattr(p, "schlick_reflectance", schlick),
         dielectric_cases),
        ("checker sign inverted", lambda: setattr(p.TTChecker, "_odd", lambda self, si: ~checker_odd(self, si)),
         lambda: setattr(p.TTChecker, "_odd", checker_odd),
         checker_case),
        # Mitsuba's `twosided` rule: the side of the shading normal alone.
        ("dielectric facing by the shading normal", lambda: setattr(
            p, "facing_sign", lambda si: dr.select(si.wi.z >= 0.0, 1.0, -1.0)),
         lambda: setattr(p, "facing_sign", facing_sign),
         dielectric_mesh_case),
    ]
    caught = 0
    for name, patch, restore, run in mutants:
        saved = (list(failures), count)
        original_pdf = GgxLobes.pdf
        patch()
        try:
            run()
        finally:
            restore()
            GgxLobes.pdf = original_pdf
        failed = len(failures) - len(saved[0])
        failures, count = saved
        ok = failed > 0
        caught += ok
        report(f"mutant {name}", ok, f"{failed} of its checks failed" if ok else "every check passed")
    return caught, len(mutants)


def main():
    for theta, wi in incidences():
        for label, d in [
            ("ggx dielectric r0.5", ggx_dict(0.0, 0.5)),
            ("ggx metal r0.3", ggx_dict(1.0, 0.3)),
            ("ggx half r0.8 coat 0.5/0.2", ggx_dict(0.5, 0.8, (0.5, 0.2))),
            ("ggx metal r0.3 coat 1/0.6", ggx_dict(1.0, 0.3, (1.0, 0.6))),
            ("fuzzy metal 0.15", fuzzy_dict(0.15)),
            ("fuzzy metal 0.6", fuzzy_dict(0.6)),
            ("fuzzy metal 1.3", fuzzy_dict(1.3)),
            ("diffuse", {"type": "tt_diffuse", "reflectance": {"type": "rgb", "value": [0.5, 0.5, 0.5]}}),
            ("ggx textured", {**ggx_dict(0.8, 0.6, (0.9, 0.5)),
                              "metallic_roughness": {"type": "rgb", "value": [1.0, 0.5, 0.25]},
                              "clearcoat_texture": {"type": "rgb", "value": [0.5, 1.0, 1.0]},
                              "clearcoat_roughness_texture": {"type": "rgb", "value": [1.0, 0.4, 1.0]},
                              "vertex_color": {"type": "rgb", "value": [0.5, 1.0, 0.25]}}),
        ]:
            chi2_case(label, d, wi)
            weight_case(label, d, wi)
    dielectric_cases()
    checker_case()
    facing_cases()
    dielectric_facing_case()
    dielectric_mesh_case()
    image_cases()
    alpha_cases()
    normalmap_cases()
    print("== mutants (each must fail its checks)", flush=True)
    caught, total = mutant_cases()
    print(f"{count - len(failures)} of {count} checks passed (each at significance {ALPHA}); "
          f"{caught} of {total} mutants caught")
    if failures:
        print("failed: " + ", ".join(failures))
        sys.exit(1)


if __name__ == "__main__":
    main()
