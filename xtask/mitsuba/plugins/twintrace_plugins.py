"""Mitsuba 3 plugins for what twintrace's reference means and Mitsuba lacks.

Each computes exactly the reference's formula (reference/src/material.rs,
reference/src/texture.rs, reference/src/sampling.rs), not an approximation:

- `tt_dielectric`: Ray Tracing in One Weekend's glass. Schlick's Fresnel
  of the incident cosine and the relative index picks reflection or
  refraction (total internal reflection always reflects); both are delta
  lobes of weight 1 (no 1/eta^2 radiance scaling, as in the reference).
  Beer-Lambert absorption is not the BSDF's: the exporter gives the shape
  an interior `homogeneous` medium of albedo 0 (`volpath` integrator).
- `tt_fuzzy_metal`: Ray Tracing in One Weekend's fuzzy metal: the mirror
  direction r plus `fuzz` times a uniform point of the unit ball,
  absorbed where that points into the surface. The direction
  w = normalize(r + fuzz*b) has a closed-form density, the mass of the
  ball's chord along w: with c = w.r and disc = c^2 - 1 + fuzz^2,
  t1,2 = c -/+ sqrt(disc), pdf(w) = (t2^3 - max(t1, 0)^3) / (4 pi fuzz^3)
  (zero where disc < 0 or t2 <= 0). So eval = albedo * pdf and the lobe is
  an ordinary glossy one that MIS can use: sampled and evaluated alike.
- `tt_ggx`: glTF metallic-roughness as `GgxLobes` (a Lambertian base
  weighted by the dielectric part's Schlick F, F0 0.04, GGX specular with height-correlated Smith G2 and
  Schlick F, visible-normal sampling, the clamped specular probability)
  under the optional clear coat (glTF's fresnel_coat mix). One-sided: the
  exporter wraps it (and `tt_fuzzy_metal`) in `twosided`, the reference's
  facing normal.
- `tt_checker`: Ray Tracing: The Next Week's 3-D sine checker at the
  render-space point (the reference's `even`/`odd` already swapped for
  the render-space origin by the scene build).
- `tt_image`: the reference's image lookup with a wrap mode per axis, or
  reading the second texture coordinates, where Mitsuba's `bitmap` (one
  mode for both axes, the first set) cannot be it.
- `tt_alpha`: glTF's alpha (MASK, BLEND) as the opacity of Mitsuba's
  `mask`.
- `tt_facing`: the reference's two-sidedness on triangles with shading
  normals: the interpolated normal put on the geometric normal's side,
  then flipped toward the side the ray arrived on by the geometric normal
  (`facing_normals`). Mitsuba's `twosided` flips by the shading normal
  alone; without shading normals the two are the same.
- `tt_normalmap`: the reference's normal map and facing around a nested
  BSDF (glTF's normalTexture with the mesh's tangents).
- `tt_diffuse`: the reference's Lambertian, which, unlike Mitsuba's
  `diffuse`, scatters whatever side of the shading normal the view is on
  (that matters only under shading normals).

`register()` registers them for the current variant; call it after
`mi.set_variant`.
"""
import drjit as dr
import mitsuba as mi

PI = 3.14159265358979323846
# reference/src/material.rs: GGX_MIN_ALPHA, DIELECTRIC_F0, LUMINANCE_WEIGHTS,
# SPECULAR_PROBABILITY_MIN/MAX.
GGX_MIN_ALPHA = 1e-4
DIELECTRIC_F0 = 0.04
LUMINANCE = (0.2126, 0.7152, 0.0722)
SPEC_MIN, SPEC_MAX = 0.05, 0.95


def _luminance(c):
    return LUMINANCE[0] * c[0] + LUMINANCE[1] * c[1] + LUMINANCE[2] * c[2]


def _fresnel_schlick(f0, cos):
    # f0 + (1 - f0) (1 - clamp(cos, 0, 1))^5, for a colour or a float f0.
    m = 1.0 - dr.clip(cos, 0.0, 1.0)
    m5 = dr.square(dr.square(m)) * m
    return f0 + (1.0 - f0) * m5


def schlick_reflectance(cos_i, eta):
    r0 = dr.square((1.0 - eta) / (1.0 + eta))
    m = 1.0 - cos_i
    return r0 + (1.0 - r0) * dr.square(dr.square(m)) * m


# --- GGX (reference/src/sampling.rs, mod ggx) -------------------------------

def ggx_d(m, alpha):
    a2 = alpha * alpha
    t = (m.x * m.x + m.y * m.y) + a2 * m.z * m.z
    return dr.select(m.z > 0.0, a2 / (PI * t * t), 0.0)


def ggx_lambda(w, alpha):
    cos2 = w.z * w.z
    tan2 = (w.x * w.x + w.y * w.y) / cos2
    lam = 0.5 * (-1.0 + dr.sqrt(1.0 + alpha * alpha * tan2))
    return dr.select(cos2 == 0.0, dr.inf, lam)


def ggx_g1(w, alpha):
    return 1.0 / (1.0 + ggx_lambda(w, alpha))


def ggx_g2(wo, wi, alpha):
    return 1.0 / (1.0 + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha))


def ggx_sample_visible_normal(wo, alpha, u):
    wo_std = dr.normalize(mi.Vector3f(wo.x * alpha, wo.y * alpha, wo.z))
    phi = 2.0 * PI * u.x
    z = (1.0 - u.y) * (1.0 + wo_std.z) - wo_std.z
    sin_theta = dr.sqrt(dr.clip(1.0 - z * z, 0.0, 1.0))
    s, c = dr.sincos(phi)
    m_std = mi.Vector3f(sin_theta * c, sin_theta * s, z) + wo_std
    return dr.normalize(mi.Vector3f(m_std.x * alpha, m_std.y * alpha, dr.maximum(m_std.z, 0.0)))


def ggx_visible_normal_pdf(wo, m, alpha):
    p = ggx_g1(wo, alpha) * dr.maximum(dr.dot(wo, m), 0.0) * ggx_d(m, alpha) / wo.z
    return dr.select(wo.z > 0.0, p, 0.0)


def reflect_about(w, m):
    """The mirror of `w` (pointing away from the surface) about `m`:
    reflect(-w, m) = 2 (w.m) m - w."""
    return 2.0 * dr.dot(w, m) * m - w


def _bsdf_sample(wo, pdf, sampled_type):
    """A one-component sample of direction `wo` (local frame) and density
    `pdf`, of lobe type `sampled_type` (a `mi.BSDFFlags`), no index change."""
    bs = dr.zeros(mi.BSDFSample3f)
    bs.wo = wo
    bs.pdf = pdf
    bs.eta = 1.0
    bs.sampled_type = mi.UInt32(+sampled_type)
    bs.sampled_component = mi.UInt32(0)
    return bs


def _set_flags(bsdf, flags):
    """One component of lobe `flags`, which are the BSDF's too."""
    bsdf.m_components = [flags]
    bsdf.m_flags = flags


def sample_cosine_hemisphere(u):
    # reference/src/sampling.rs: Shirley-Chiu concentric disk, lifted.
    o = 2.0 * u - 1.0
    use_x = dr.abs(o.x) > dr.abs(o.y)
    r = dr.select(use_x, o.x, o.y)
    theta = dr.select(use_x, (PI / 4.0) * (o.y / o.x), PI / 2.0 - (PI / 4.0) * (o.x / o.y))
    zero = (o.x == 0.0) & (o.y == 0.0)
    s, c = dr.sincos(theta)
    dx = dr.select(zero, 0.0, r * c)
    dy = dr.select(zero, 0.0, r * s)
    z = dr.sqrt(dr.maximum(1.0 - (dx * dx + dy * dy), 0.0))
    return mi.Vector3f(dx, dy, z)


class GgxLobes:
    """reference/src/material.rs `GgxLobes`, vectorized, in the local frame."""

    def __init__(self, base_color, metallic, roughness, coat, coat_roughness, wo):
        self.base_color = base_color
        self.metallic = metallic
        self.alpha = dr.maximum(roughness * roughness, GGX_MIN_ALPHA)
        self.f0 = dr.lerp(mi.Color3f(DIELECTRIC_F0), base_color, metallic)
        spec = _luminance(_fresnel_schlick(self.f0, wo.z))
        diff = _luminance(base_color) * (1.0 - metallic) * (1.0 - spec)
        self.specular_probability = dr.select(
            diff <= 0.0, 1.0, dr.clip(spec / (spec + diff), SPEC_MIN, SPEC_MAX))
        has_coat = coat > 0.0
        self.coat = dr.select(has_coat, coat * _fresnel_schlick(DIELECTRIC_F0, wo.z), 0.0)
        self.coat_alpha = dr.select(
            has_coat, dr.maximum(coat_roughness * coat_roughness, GGX_MIN_ALPHA), GGX_MIN_ALPHA)

    def eval(self, wo, wi):
        valid = (wo.z > 0.0) & (wi.z > 0.0)
        h = dr.normalize(wo + wi)
        f = _fresnel_schlick(self.f0, dr.dot(wi, h))
        spec = f * (ggx_d(h, self.alpha) * ggx_g2(wo, wi, self.alpha) / (4.0 * wo.z * wi.z))
        # glTF's mix: the diffuse under the dielectric part's own F0 0.04.
        f_dielectric = _fresnel_schlick(DIELECTRIC_F0, dr.dot(wi, h))
        diffuse = (1.0 - f_dielectric) * (1.0 - self.metallic) * self.base_color * (1.0 / PI)
        base = spec + diffuse
        a = self.coat_alpha
        coat = ggx_d(h, a) * ggx_g2(wo, wi, a) / (4.0 * wo.z * wi.z)
        value = dr.select(self.coat > 0.0, (1.0 - self.coat) * base + self.coat * coat, base)
        return dr.select(valid, value, 0.0)

    def pdf(self, wo, wi):
        valid = (wo.z > 0.0) & (wi.z > 0.0)
        h = dr.normalize(wo + wi)
        spec_pdf = ggx_visible_normal_pdf(wo, h, self.alpha) / (4.0 * dr.dot(wo, h))
        p = self.specular_probability
        base = p * spec_pdf + (1.0 - p) * wi.z * (1.0 / PI)
        coat_pdf = ggx_visible_normal_pdf(wo, h, self.coat_alpha) / (4.0 * dr.dot(wo, h))
        value = dr.select(self.coat > 0.0, self.coat * coat_pdf + (1.0 - self.coat) * base, base)
        return dr.select(valid, value, 0.0)

    def sample(self, wo, lobe, u):
        """The direction `scatter` samples (one number picks the lobe: [0,
        coat) the coat, then the base's specular share, then diffuse)."""
        m_coat = ggx_sample_visible_normal(wo, self.coat_alpha, u)
        m_spec = ggx_sample_visible_normal(wo, self.alpha, u)
        pick_coat = lobe < self.coat
        pick_spec = ~pick_coat & (lobe < self.coat + (1.0 - self.coat) * self.specular_probability)
        m = dr.select(pick_coat, m_coat, m_spec)
        return dr.select(pick_coat | pick_spec, reflect_about(wo, m), sample_cosine_hemisphere(u))


class TTGgx(mi.BSDF):
    def __init__(self, props):
        mi.BSDF.__init__(self, props)
        self.base_color = props.get_texture("base_color", 0.5)
        self.metallic = props.get("metallic", 0.0)
        self.roughness = props.get("roughness", 0.5)
        # Textured factors (glTF's metallicRoughnessTexture: blue metallic,
        # green roughness; clearcoatTexture red, clearcoatRoughnessTexture
        # green), each the factor times the channel, as ggx_parameters and
        # coat_parameters do.
        self.metallic_roughness = props.get_texture("metallic_roughness", 1.0) \
            if props.has_property("metallic_roughness") else None
        # The vertex colour (a `mesh_attribute` texture) scales the base
        # colour (TextureContext::base_color).
        self.vertex_color = props.get_texture("vertex_color", 1.0) \
            if props.has_property("vertex_color") else None
        self.coat = props.get("clearcoat", 0.0)
        self.coat_texture = props.get_texture("clearcoat_texture", 1.0) \
            if props.has_property("clearcoat_texture") else None
        self.coat_roughness = props.get("clearcoat_roughness", 0.0)
        self.coat_roughness_texture = props.get_texture("clearcoat_roughness_texture", 1.0) \
            if props.has_property("clearcoat_roughness_texture") else None
        _set_flags(self, mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.DiffuseReflection
                   | mi.BSDFFlags.FrontSide)

    def lobes(self, si):
        wo = si.wi
        metallic, roughness = mi.Float(self.metallic), mi.Float(self.roughness)
        if self.metallic_roughness is not None:
            t = self.metallic_roughness.eval(si)
            metallic, roughness = metallic * t[2], roughness * t[1]
        coat, coat_roughness = mi.Float(self.coat), mi.Float(self.coat_roughness)
        if self.coat_texture is not None:
            coat = coat * self.coat_texture.eval(si)[0]
        if self.coat_roughness_texture is not None:
            coat_roughness = coat_roughness * self.coat_roughness_texture.eval(si)[1]
        base = mi.Color3f(self.base_color.eval(si))
        if self.vertex_color is not None:
            base = base * mi.Color3f(self.vertex_color.eval(si))
        return GgxLobes(base, metallic, roughness, coat, coat_roughness, wo)

    def sample(self, ctx, si, sample1, sample2, active=True):
        wo = si.wi
        lobes = self.lobes(si)
        wi = lobes.sample(wo, sample1, sample2)
        pdf = lobes.pdf(wo, wi)
        ok = active & (wo.z > 0.0) & (wi.z > 0.0) & (pdf > 0.0)
        bs = _bsdf_sample(wi, dr.select(ok, pdf, 0.0), mi.BSDFFlags.GlossyReflection)
        weight = dr.select(ok, lobes.eval(wo, wi) * wi.z / pdf, 0.0)
        return bs, mi.Color3f(weight)

    def eval(self, ctx, si, wo, active=True):
        lobes = self.lobes(si)
        return mi.Color3f(dr.select(active, lobes.eval(si.wi, wo) * dr.maximum(wo.z, 0.0), 0.0))

    def pdf(self, ctx, si, wo, active=True):
        return dr.select(active, self.lobes(si).pdf(si.wi, wo), 0.0)

    def eval_pdf(self, ctx, si, wo, active=True):
        lobes = self.lobes(si)
        value = lobes.eval(si.wi, wo) * dr.maximum(wo.z, 0.0)
        return mi.Color3f(dr.select(active, value, 0.0)), dr.select(active, lobes.pdf(si.wi, wo), 0.0)

    def to_string(self):
        return "TTGgx[]"


def fuzzy_pdf(w, r, fuzz):
    """The density (solid angle) of normalize(r + fuzz*b), b uniform in the
    unit ball, |r| = 1, at unit `w` (see the module's note)."""
    c = dr.dot(w, r)
    disc = c * c - 1.0 + fuzz * fuzz
    root = dr.sqrt(dr.maximum(disc, 0.0))
    hi = c + root
    lo = dr.maximum(c - root, 0.0)
    # hi^3 - lo^3 = (hi - lo)(hi^2 + hi lo + lo^2), without the cancellation.
    mass = (hi - lo) * (hi * hi + hi * lo + lo * lo)
    p = mass / (4.0 * PI * fuzz * fuzz * fuzz)
    return dr.select((disc > 0.0) & (hi > 0.0), p, 0.0)


class TTFuzzyMetal(mi.BSDF):
    def __init__(self, props):
        mi.BSDF.__init__(self, props)
        self.albedo = props.get_texture("albedo", 1.0)
        self.fuzz = props.get("fuzz", 0.1)
        _set_flags(self, mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide)

    def sample(self, ctx, si, sample1, sample2, active=True):
        wi = si.wi
        r = mi.Vector3f(-wi.x, -wi.y, wi.z)
        # A uniform point of the unit ball: a uniform direction times the
        # cube root of a uniform radius (reference sample_unit_ball).
        z = 1.0 - 2.0 * sample2.x
        rr = dr.sqrt(dr.maximum(1.0 - z * z, 0.0))
        s, c = dr.sincos(2.0 * PI * sample2.y)
        ball = mi.Vector3f(rr * c, rr * s, z) * dr.cbrt(sample1)
        d = r + self.fuzz * ball
        wo = dr.normalize(d)
        pdf = fuzzy_pdf(wo, r, self.fuzz)
        ok = active & (wi.z > 0.0) & (d.z > 0.0) & (pdf > 0.0)
        bs = _bsdf_sample(wo, dr.select(ok, pdf, 0.0), mi.BSDFFlags.GlossyReflection)
        weight = dr.select(ok, mi.Color3f(self.albedo.eval(si)), 0.0)
        return bs, weight

    def _pdf(self, si, wo, active):
        wi = si.wi
        r = mi.Vector3f(-wi.x, -wi.y, wi.z)
        ok = active & (wi.z > 0.0) & (wo.z > 0.0)
        return dr.select(ok, fuzzy_pdf(wo, r, self.fuzz), 0.0)

    def eval(self, ctx, si, wo, active=True):
        return mi.Color3f(self.albedo.eval(si)) * self._pdf(si, wo, active)

    def pdf(self, ctx, si, wo, active=True):
        return self._pdf(si, wo, active)

    def eval_pdf(self, ctx, si, wo, active=True):
        p = self._pdf(si, wo, active)
        return mi.Color3f(self.albedo.eval(si)) * p, p

    def to_string(self):
        return "TTFuzzyMetal[]"


class TTDielectric(mi.BSDF):
    def __init__(self, props):
        mi.BSDF.__init__(self, props)
        self.ior = props.get("ior", 1.5)
        # On triangles with shading normals (see `facing_sign`).
        self.facing = props.get("facing", False)
        reflection = mi.BSDFFlags.DeltaReflection | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
        transmission = mi.BSDFFlags.DeltaTransmission | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
        self.m_components = [reflection, transmission]
        self.m_flags = reflection | transmission

    def sample(self, ctx, si, sample1, sample2, active=True):
        wi = si.wi
        if self.facing:
            # Under shading normals: the side by the geometric normal, the
            # normal the reference's facing one (`facing_sign`).
            front = dr.dot(wi, si.to_local(si.n)) > 0.0
            nz = facing_sign(si)
        else:
            front = wi.z >= 0.0
            nz = dr.select(front, 1.0, -1.0)
        eta = dr.select(front, 1.0 / self.ior, self.ior)
        # The reference's refract of the ray direction d = -wi about the
        # facing normal n = (0, 0, nz).
        cos_i = dr.minimum(nz * wi.z, 1.0)
        sin2_t = eta * eta * dr.maximum(1.0 - cos_i * cos_i, 0.0)
        tir = sin2_t >= 1.0
        cos_t = dr.sqrt(dr.maximum(1.0 - sin2_t, 0.0))
        refracted = dr.normalize(-eta * wi + mi.Vector3f(0.0, 0.0, (eta * cos_i - cos_t) * nz))
        reflected = mi.Vector3f(-wi.x, -wi.y, wi.z)
        r = schlick_reflectance(cos_i, eta)
        refract = ~tir & (r <= sample1)
        bs = dr.zeros(mi.BSDFSample3f)
        bs.wo = dr.select(refract, refracted, reflected)
        bs.pdf = dr.select(tir, 1.0, dr.select(refract, 1.0 - r, r))
        bs.eta = 1.0
        bs.sampled_type = dr.select(refract, mi.UInt32(+mi.BSDFFlags.DeltaTransmission),
                                    mi.UInt32(+mi.BSDFFlags.DeltaReflection))
        bs.sampled_component = dr.select(refract, mi.UInt32(1), mi.UInt32(0))
        return bs, mi.Color3f(dr.select(active & (bs.pdf > 0.0), 1.0, 0.0))

    def eval(self, ctx, si, wo, active=True):
        return mi.Color3f(0.0)

    def pdf(self, ctx, si, wo, active=True):
        return mi.Float(0.0)

    def eval_pdf(self, ctx, si, wo, active=True):
        return mi.Color3f(0.0), mi.Float(0.0)

    def to_string(self):
        return "TTDielectric[]"


class TTChecker(mi.Texture):
    def __init__(self, props):
        mi.Texture.__init__(self, props)
        self.scale = props.get("scale", 1.0)
        self.even = props.get_texture("even", 0.0)
        self.odd = props.get_texture("odd", 1.0)

    def _odd(self, si):
        p = si.p
        s = self.scale
        return dr.sin(s * p.x) * dr.sin(s * p.y) * dr.sin(s * p.z) < 0.0

    def eval(self, si, active=True):
        return dr.select(self._odd(si), self.odd.eval(si, active), self.even.eval(si, active))

    def eval_1(self, si, active=True):
        return dr.select(self._odd(si), self.odd.eval_1(si, active), self.even.eval_1(si, active))

    def eval_3(self, si, active=True):
        return dr.select(self._odd(si), self.odd.eval_3(si, active), self.even.eval_3(si, active))

    def mean(self):
        return 0.5 * (self.even.mean() + self.odd.mean())

    def max(self):
        return dr.maximum(self.even.max(), self.odd.max())

    def is_spatially_varying(self):
        return True

    def to_string(self):
        return "TTChecker[]"


def _flip(v, s):
    return mi.Vector3f(v.x, v.y, s * v.z)


def facing_sign(si):
    """+1 where the reference's facing shading normal is the shading
    frame's +z, -1 where it is -z: (front ? 1 : -1) * (n.ng < 0 ? -1 : 1)."""
    ng = si.to_local(si.n)
    front = dr.dot(si.wi, ng) > 0.0
    side = ng.z >= 0.0
    return dr.select(front == side, 1.0, -1.0)


class _Wrapper(mi.BSDF):
    """A nested BSDF evaluated in another local frame: a subclass's
    `_turned(si)` gives (`inward`, `outward`, si2): the nested BSDF sees
    the interaction si2, and a direction `w` of the outer local frame as
    `inward(w)`; its sampled directions come back through `outward`."""

    def __init__(self, props, plugin):
        mi.BSDF.__init__(self, props)
        self.nested = None
        for name in props.property_names():
            v = props.get(name)
            if isinstance(v, mi.BSDF):
                self.nested = v
        if self.nested is None:
            raise RuntimeError(f"{plugin}: needs a nested BSDF")
        _set_flags(self, self.nested.flags() | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide)

    def sample(self, ctx, si, sample1, sample2, active=True):
        _, outward, si2 = self._turned(si)
        bs, weight = self.nested.sample(ctx, si2, sample1, sample2, active)
        bs.wo = outward(bs.wo)
        return bs, weight

    def eval(self, ctx, si, wo, active=True):
        inward, _, si2 = self._turned(si)
        return self.nested.eval(ctx, si2, inward(wo), active)

    def pdf(self, ctx, si, wo, active=True):
        inward, _, si2 = self._turned(si)
        return self.nested.pdf(ctx, si2, inward(wo), active)

    def eval_pdf(self, ctx, si, wo, active=True):
        inward, _, si2 = self._turned(si)
        return self.nested.eval_pdf(ctx, si2, inward(wo), active)

    def traverse(self, callback):
        pass


class TTFacing(_Wrapper):
    def __init__(self, props):
        _Wrapper.__init__(self, props, "tt_facing")

    def _turned(self, si):
        s = facing_sign(si)
        flip = lambda v: _flip(v, s)  # noqa: E731
        si2 = mi.SurfaceInteraction3f(si)
        si2.wi = flip(si.wi)
        return flip, flip, si2

    def to_string(self):
        return "TTFacing[]"


class TTNormalMap(_Wrapper):
    """The reference's normal map (`normal_mapped`, glTF's normalTexture)
    and facing around a nested BSDF: the tangent (`vertex_tangent`) made
    orthogonal to the interpolated normal n, the bitangent sign(w) n x t
    (`vertex_tsign`: w in each channel), the texel c taken as the normal
    (2c - 1) with x, y times `scale` in that frame, put on the geometric
    normal's side, the unmapped normal kept where the result is not on
    the geometric side or the frame is degenerate; then flipped toward the
    side the ray arrived on. The nested BSDF is evaluated in that frame."""

    def __init__(self, props):
        _Wrapper.__init__(self, props, "tt_normalmap")
        self.normal_map = props.get_texture("normal_map", 0.5)
        self.scale = props.get("scale", 1.0)
        self.tangent = props.get_texture("tangent", 0.0)
        self.tsign = props.get_texture("tsign", 1.0)

    def frame(self, si):
        n = si.sh_frame.n
        ng = si.n
        side = dr.select(dr.dot(n, ng) < 0.0, -1.0, 1.0)
        t4 = mi.Vector3f(self.tangent.eval(si))
        w = mi.Color3f(self.tsign.eval(si))[0]
        t = t4 - n * dr.dot(n, t4)
        tl = dr.norm(t)
        ok = (tl > 0.0) & dr.isfinite(tl)
        t = t / dr.select(ok, tl, 1.0)
        b = dr.cross(n, t) * dr.select(w < 0.0, -1.0, 1.0)
        texel = mi.Color3f(self.normal_map.eval(si))
        mx = (2.0 * texel[0] - 1.0) * self.scale
        my = (2.0 * texel[1] - 1.0) * self.scale
        mz = 2.0 * texel[2] - 1.0
        v = mx * t + my * b + mz * n
        vl = dr.norm(v)
        mapped = side * v / dr.select(vl > 0.0, vl, 1.0)
        ok &= (vl > 0.0) & (dr.dot(mapped, ng) > 0.0)
        ns = dr.select(ok, mapped, side * n)
        front = dr.dot(si.to_world(si.wi), ng) > 0.0
        return mi.Frame3f(dr.select(front, ns, -ns))

    def _turned(self, si):
        f = self.frame(si)
        inward = lambda w: f.to_local(si.to_world(w))  # noqa: E731
        outward = lambda w: si.to_local(f.to_world(w))  # noqa: E731
        si2 = mi.SurfaceInteraction3f(si)
        si2.sh_frame = f
        si2.wi = inward(si.wi)
        return inward, outward, si2

    def to_string(self):
        return "TTNormalMap[]"


class TTDiffuse(mi.BSDF):
    def __init__(self, props):
        mi.BSDF.__init__(self, props)
        self.reflectance = props.get_texture("reflectance", 0.5)
        _set_flags(self, mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide)

    def sample(self, ctx, si, sample1, sample2, active=True):
        wo = sample_cosine_hemisphere(sample2)
        bs = _bsdf_sample(wo, wo.z * (1.0 / PI), mi.BSDFFlags.DiffuseReflection)
        ok = active & (bs.pdf > 0.0)
        return bs, dr.select(ok, mi.Color3f(self.reflectance.eval(si)), 0.0)

    def eval(self, ctx, si, wo, active=True):
        cos = dr.maximum(wo.z, 0.0)
        return dr.select(active, mi.Color3f(self.reflectance.eval(si)) * (cos / PI), 0.0)

    def pdf(self, ctx, si, wo, active=True):
        return dr.select(active, dr.maximum(wo.z, 0.0) / PI, 0.0)

    def eval_pdf(self, ctx, si, wo, active=True):
        return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

    def to_string(self):
        return "TTDiffuse[]"


def _wrap_coordinate(c, mode):
    if mode == "repeat":
        return c - dr.floor(c)
    if mode == "clamp":
        return dr.clip(c, 0.0, 1.0)
    t = c - 2.0 * dr.floor(0.5 * c)
    return dr.select(t > 1.0, 2.0 - t, t)


def _wrap_index(i, n, mode):
    # i: a whole number as a float, perhaps outside the image.
    if mode == "repeat":
        k = i - n * dr.floor(i / n)
    elif mode == "clamp":
        k = dr.clip(i, 0.0, n - 1.0)
    else:
        m = i - 2.0 * n * dr.floor(i / (2.0 * n))
        k = dr.select(m >= n, 2.0 * n - 1.0 - m, m)
    return mi.UInt32(dr.clip(k, 0.0, n - 1.0))


class TTImage(mi.Texture):
    """The reference's image lookup (`ImageData::sample_image`) where
    Mitsuba's `bitmap` cannot be it: a wrap mode per axis (glTF's wrapS,
    wrapT). The texels are the EXR's as they are (the exporter writes the
    reference's linear texels times the factor); `uv_map` (six numbers)
    takes the shape's uv to the sampler's (the reference's uv and
    KHR_texture_transform); v = 0 is the bottom row, texel centres at
    half-integers, then the nearest texel or bilinear filtering."""

    def __init__(self, props):
        mi.Texture.__init__(self, props)
        import numpy as np
        # Relative to the scene file, as Mitsuba's own plugins resolve it.
        path = mi.Thread.thread().file_resolver().resolve(props.get("filename"))
        bitmap = mi.Bitmap(str(path))
        data = np.array(bitmap, dtype=np.float32)[:, :, :3]
        self.h, self.w = data.shape[0], data.shape[1]
        self.data = mi.Float(data.ravel())
        self.wrap_u = props.get("wrap_u", "repeat")
        self.wrap_v = props.get("wrap_v", "repeat")
        self.nearest = props.get("nearest", False)
        self.m = [props.get(f"m{i}", [1.0, 0.0, 0.0, 0.0, 1.0, 0.0][i]) for i in range(6)]
        self.mean_value = mi.Color3f(*[float(data[:, :, k].mean()) for k in range(3)])
        # glTF's texCoord 1: the second set, a `mesh_attribute` (u, v, 0).
        self.uv1 = props.get_texture("uv1", 0.0) if props.has_property("uv1") else None

    def _texel(self, xi, yi):
        idx = 3 * (yi * self.w + xi)
        return mi.Color3f(dr.gather(mi.Float, self.data, idx),
                          dr.gather(mi.Float, self.data, idx + 1),
                          dr.gather(mi.Float, self.data, idx + 2))

    def eval(self, si, active=True):
        m = self.m
        if self.uv1 is not None:
            c = mi.Color3f(self.uv1.eval(si))
            su, sv = c[0], c[1]
        else:
            su, sv = si.uv.x, si.uv.y
        u = m[0] * su + m[1] * sv + m[2]
        v = m[3] * su + m[4] * sv + m[5]
        w, h = float(self.w), float(self.h)
        x = _wrap_coordinate(u, self.wrap_u) * w - 0.5
        y = (1.0 - _wrap_coordinate(v, self.wrap_v)) * h - 0.5
        if self.nearest:
            xi = _wrap_index(dr.floor(x + 0.5), w, self.wrap_u)
            yi = _wrap_index(dr.floor(y + 0.5), h, self.wrap_v)
            return self._texel(xi, yi)
        x0, y0 = dr.floor(x), dr.floor(y)
        fx, fy = x - x0, y - y0
        xa, xb = _wrap_index(x0, w, self.wrap_u), _wrap_index(x0 + 1.0, w, self.wrap_u)
        ya, yb = _wrap_index(y0, h, self.wrap_v), _wrap_index(y0 + 1.0, h, self.wrap_v)
        top = dr.lerp(self._texel(xa, ya), self._texel(xb, ya), fx)
        bottom = dr.lerp(self._texel(xa, yb), self._texel(xb, yb), fx)
        return dr.lerp(top, bottom, fy)

    def eval_3(self, si, active=True):
        return self.eval(si, active)

    def eval_1(self, si, active=True):
        return self.eval(si, active)[0]

    def mean(self):
        return dr.mean(self.mean_value)

    def is_spatially_varying(self):
        return True

    def to_string(self):
        return "TTImage[]"


class TTAlpha(mi.Texture):
    """glTF's alpha as the reference decides coverage
    (`Scene::alpha_covers`): the `alpha` texture's first channel times the
    vertex colour's alpha (`vertex_alpha`, where the mesh has one); MASK
    (`cutoff` >= 0): opacity 1 where that is at least the cutoff, else 0;
    BLEND (no cutoff): opacity alpha, the probability with which the
    reference's hashed test covers. Mitsuba's `mask` BSDF reads it; the
    `volpath` integrator passes shadow rays through the uncovered share,
    as the reference's traversal does for every ray."""

    def __init__(self, props):
        mi.Texture.__init__(self, props)
        self.alpha = props.get_texture("alpha", 1.0)
        self.vertex_alpha = props.get_texture("vertex_alpha", 1.0) \
            if props.has_property("vertex_alpha") else None
        self.cutoff = props.get("cutoff", -1.0)

    def eval_1(self, si, active=True):
        a = mi.Color3f(self.alpha.eval(si))[0]
        if self.vertex_alpha is not None:
            a = a * mi.Color3f(self.vertex_alpha.eval(si))[0]
        if self.cutoff >= 0.0:
            return dr.select(a >= self.cutoff, 1.0, 0.0)
        return dr.clip(a, 0.0, 1.0)

    def eval(self, si, active=True):
        return mi.Color3f(self.eval_1(si, active))

    def eval_3(self, si, active=True):
        return self.eval(si, active)

    def mean(self):
        return 0.5

    def is_spatially_varying(self):
        return True

    def to_string(self):
        return "TTAlpha[]"


def register():
    mi.register_bsdf("tt_dielectric", lambda props: TTDielectric(props))
    mi.register_bsdf("tt_fuzzy_metal", lambda props: TTFuzzyMetal(props))
    mi.register_bsdf("tt_ggx", lambda props: TTGgx(props))
    mi.register_bsdf("tt_facing", lambda props: TTFacing(props))
    mi.register_bsdf("tt_diffuse", lambda props: TTDiffuse(props))
    mi.register_bsdf("tt_normalmap", lambda props: TTNormalMap(props))
    mi.register_texture("tt_checker", lambda props: TTChecker(props))
    mi.register_texture("tt_image", lambda props: TTImage(props))
    mi.register_texture("tt_alpha", lambda props: TTAlpha(props))
