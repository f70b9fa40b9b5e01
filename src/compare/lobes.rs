//! Scatter-direction samples of one material at one surface point: the
//! CPU half of the two-sample chi-square tests for lobes without a density
//! (mirror, dielectric, Ray Tracing in One Weekend's fuzzy metal).
//!
//! A [`LobeCase`] fixes the material, the side hit and the incoming
//! direction (fixed, or random per sample). The surface is the plane
//! `z = 0` with normal +z, so sampled directions are already in the local
//! frame of [`super::chi2::Domain::Sphere`]. Sample `i` of a run reads the
//! vertex randoms `rng::vertex_randoms(seed, i, 0, 1)`, the slots the tracer
//! reads at its first bounce; a random incidence reads its own stream
//! (bounce 2). A GPU implementation fed the same cases and seeds must give
//! the same distribution, which [`super::chi2::test_same_distribution`]
//! checks.

use glam::{DVec3, Vec2, Vec3};
use reference::geometry::SurfaceInteraction;
use reference::material::{Material, Scatter, TextureContext};
use reference::rng;
use reference::sampling::sample_cosine_hemisphere;
use reference::texture::Texture;

/// Where the incoming ray comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Incidence {
    /// This ray direction (unit, travelling toward the surface).
    Fixed(Vec3),
    /// Cosine-distributed about the normal on the side hit, per sample.
    Random,
}

/// One material, one side, one incidence.
#[derive(Clone, Debug, PartialEq)]
pub struct LobeCase {
    pub name: String,
    pub material: Material,
    pub textures: Vec<Texture>,
    /// Whether the ray hits the side the normal (+z) points to.
    pub front_face: bool,
    pub incidence: Incidence,
}

/// The signature of [`reference::material::scatter`], so that a mutated
/// copy can stand in for it.
pub type ScatterFn =
    dyn Fn(&Material, TextureContext, Vec3, &SurfaceInteraction, &[f32; 8]) -> Option<Scatter>;

impl LobeCase {
    /// The surface point: origin, normal +z.
    pub fn surface(&self) -> SurfaceInteraction {
        SurfaceInteraction {
            p: Vec3::ZERO,
            geometric_normal: Vec3::Z,
            shading_normal: Vec3::Z,
            uv: Vec2::ZERO,
            uv1: Vec2::ZERO,
            color: Vec3::ONE,
            p_error: 0.0,
            front_face: self.front_face,
            material: 0,
            tangent: Vec3::X,
            bitangent: Vec3::Y,
            dp_du: Vec3::X,
            dp_dv: Vec3::Y,
        }
    }

    /// The incoming ray direction of sample `i`.
    pub fn ray_direction(&self, seed: u32, i: u32) -> Vec3 {
        let d = match self.incidence {
            Incidence::Fixed(d) => return d,
            Incidence::Random => {
                let u = rng::vertex_randoms(seed, i, 0, 2);
                sample_cosine_hemisphere(Vec2::new(u[0], u[1]))
            }
        };
        // Toward the surface from the side hit: downward onto the front.
        if self.front_face {
            -d
        } else {
            d
        }
    }

    /// `n` scattered directions (`None`: absorbed) from `scatter`.
    pub fn samples_with(&self, seed: u32, n: u32, scatter: &ScatterFn) -> Vec<Option<DVec3>> {
        let si = self.surface();
        let ctx = TextureContext {
            textures: &self.textures,
            images: &[],
        };
        (0..n)
            .map(|i| {
                let u = rng::vertex_randoms(seed, i, 0, 1);
                scatter(&self.material, ctx, self.ray_direction(seed, i), &si, &u)
                    .map(|s| s.direction.as_dvec3())
            })
            .collect()
    }

    /// `n` directions from the reference's own scatter.
    pub fn cpu_samples(&self, seed: u32, n: u32) -> Vec<Option<DVec3>> {
        self.samples_with(seed, n, &reference::material::scatter)
    }
}

/// The delta and density-less lobes every backend must reproduce: a
/// mirror, a conductor (both sides), glass (Schlick's and the exact
/// Fresnel's) from outside and from inside, a thin glass sheet (where total internal
/// reflection happens), fuzzy metal at two fuzz values; fixed and random
/// incidences.
pub fn standard_cases() -> Vec<LobeCase> {
    let white = vec![Texture::Constant(Vec3::ONE)];
    let at = |deg: f32| {
        let t = deg.to_radians();
        Vec3::new(t.sin(), 0.0, -t.cos())
    };
    let case = |name: &str, material: Material, front_face: bool, incidence: Incidence| LobeCase {
        name: name.into(),
        material,
        textures: white.clone(),
        front_face,
        incidence,
    };
    let mirror = Material::Metal {
        albedo: 0,
        fuzz: 0.0,
    };
    let glass = Material::Dielectric {
        ior: 1.5,
        absorption: Vec3::ZERO,
    };
    let gold = Material::Conductor {
        specular: 0,
        eta: Vec3::new(0.143, 0.374, 1.442),
        k: Vec3::new(3.983, 2.385, 1.603),
    };
    let pyrex = Material::SmoothDielectric {
        eta: 1.47,
        reflectance: 0,
        transmittance: 0,
    };
    let sheet = Material::ThinDielectric {
        eta: 1.6,
        reflectance: 0,
        transmittance: 0,
    };
    let inside = |deg: f32| {
        let d = at(deg);
        Vec3::new(d.x, d.y, -d.z)
    };
    vec![
        case(
            "mirror, 30° incidence",
            mirror,
            true,
            Incidence::Fixed(at(30.0)),
        ),
        case("mirror, random incidence", mirror, true, Incidence::Random),
        case(
            "glass from outside, 0°",
            glass,
            true,
            Incidence::Fixed(at(0.0)),
        ),
        case(
            "glass from outside, 70°",
            glass,
            true,
            Incidence::Fixed(at(70.0)),
        ),
        case(
            "glass from outside, random incidence",
            glass,
            true,
            Incidence::Random,
        ),
        case(
            "glass from inside, 30° (refracts or reflects)",
            glass,
            false,
            Incidence::Fixed(inside(30.0)),
        ),
        case(
            "glass from inside, random incidence (total internal reflection beyond 41.8°)",
            glass,
            false,
            Incidence::Random,
        ),
        case(
            "conductor (gold's index), 40°",
            gold,
            true,
            Incidence::Fixed(at(40.0)),
        ),
        case(
            "conductor (gold's index), random incidence",
            gold,
            true,
            Incidence::Random,
        ),
        case(
            "conductor from its back side, random incidence",
            gold,
            false,
            Incidence::Random,
        ),
        case(
            "smooth dielectric from outside, random incidence",
            pyrex,
            true,
            Incidence::Random,
        ),
        case(
            "smooth dielectric from inside, random incidence (total internal reflection beyond 42.9°)",
            pyrex,
            false,
            Incidence::Random,
        ),
        case("thin dielectric, random incidence", sheet, true, Incidence::Random),
        case(
            "thin dielectric from its back, random incidence",
            sheet,
            false,
            Incidence::Random,
        ),
        case(
            "fuzzy metal 0.3, 45°",
            Material::Metal {
                albedo: 0,
                fuzz: 0.3,
            },
            true,
            Incidence::Fixed(at(45.0)),
        ),
        case(
            "fuzzy metal 1.0, 60° (some absorbed)",
            Material::Metal {
                albedo: 0,
                fuzz: 1.0,
            },
            true,
            Incidence::Fixed(at(60.0)),
        ),
        case(
            "fuzzy metal 0.5, random incidence",
            Material::Metal {
                albedo: 0,
                fuzz: 0.5,
            },
            true,
            Incidence::Random,
        ),
    ]
}
