//! Specialization: the render kernel built without the code a scene does
//! not use ("skip what a scene doesn't need").
//!
//! [`Features::of`] inspects a scene (its primitive kinds, materials,
//! textures and background) and the WGSL pipeline-overridable constants
//! `FEATURES` and `FEATURES_HI` (a bit per feature, the low and high 32
//! of 64: [`Features::constants`]) are set to it when the pipeline is
//! made. Every `switch` case of a feature starts with
//! `if !uses(FEATURE_…) { poison(); … }`, and the few branches outside a
//! switch test `uses(FEATURE_…) && …` (the light sampler's sphere and
//! triangle paths, the dielectric's absorption, the environment's density;
//! each lies on a path that also passes a poisoning case): with the
//! constant known, the compiler drops that code, so the kernel holds only
//! the scene's code (fewer instructions and registers), and a kernel that
//! met a feature its specialization left out reports poisoned samples
//! rather than a wrong image. The default, [`Features::ALL`], is the general kernel:
//! the oracle the specialized one is gated against (every fixture, under
//! the GPU-against-GPU rule of `twintrace::twins::film_words`:
//! tests/gpu/gpu_specialization.rs).
//!
//! The kernel axis itself ([`Kernel`]) and the dispatch axis ([`Dispatch`],
//! with its constant) are defined in `crate::variants` and re-exported
//! here; [`Kernel::features`] is here, with the feature sets.

use reference::background::Background;
use reference::light::punctual_tag;
use reference::material::Material;
use reference::scene::{primitive_tag, Scene};
use reference::texture::Texture;

pub use crate::variants::{
    Dispatch, Kernel, DISPATCH_BRANCHES, DISPATCH_CONSTANT, DISPATCH_SWITCH,
};

/// The render program's pipeline-overridable constants that hold the
/// scene's [`Features`]: bits 0–31 and 32–63 (WGSL has no 64-bit
/// constant; a `FEATURE_…` constant is the pair of words, and `uses`
/// tests both).
pub const FEATURES_CONSTANT: &str = "FEATURES";
pub const FEATURES_HI_CONSTANT: &str = "FEATURES_HI";

/// Declares each feature bit once: its Rust constant and, in [`NAMED`],
/// the WGSL constant `FEATURE_<NAME>` generated from it.
macro_rules! feature_bits {
    ($($name:ident = $bit:literal,)*) => {
        /// The feature bits (the WGSL constants `FEATURE_…`).
        pub mod feature {
            $(pub const $name: u64 = 1 << $bit;)*

            /// Every bit, with its WGSL name (for the generated constants).
            pub const NAMED: &[(&str, u64)] = &[$((concat!("FEATURE_", stringify!($name)), $name),)*];
        }
    };
}

feature_bits! {
    SPHERES = 0,
    QUADS = 1,
    TRIANGLES = 2,
    LAMBERTIAN = 3,
    METAL = 4,
    DIELECTRIC = 5,
    GGX = 6,
    IMAGE_TEXTURES = 7,
    CHECKER_TEXTURES = 8,
    SOLID_BACKGROUND = 9,
    SKY_BACKGROUND = 10,
    ENVMAP_BACKGROUND = 11,
    NORMAL_MAPS = 12,
    ALPHA = 13,
    CLEARCOAT = 14,
    EMISSIVE_BSDFS = 15,
    PUNCTUAL_LIGHTS = 16,
    UV_CHECKER_TEXTURES = 17,
    CONDUCTOR = 18,
    SMOOTH_DIELECTRIC = 19,
    THIN_DIELECTRIC = 20,
    ROUGH_CONDUCTOR = 21,
    BECKMANN = 22,
    ROUGH_DIELECTRIC = 23,
    PLASTIC = 24,
    ROUGH_PLASTIC = 25,
    MASK = 26,
    ONE_SIDED = 27,
    VERTEX_COLOR_TEXTURES = 28,
    PROFILED_LIGHTS = 29,
    TANGENT_FRAME = 30,
    BLEND = 31,
    PRINCIPLED = 32,
    PRINCIPLED_THIN = 33,
    QUADRICS = 34,
    SDF_GRIDS = 35,
    INSTANCES = 36,
}

impl Kernel {
    /// The feature set the kernel is built for.
    pub fn features(self, scene: &Scene) -> Features {
        match self {
            Kernel::Specialized => Features::of(scene),
            Kernel::General => Features::ALL,
        }
    }
}

/// A set of feature bits ([`feature`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Features(pub u64);

impl Features {
    /// Every feature: the general kernel (the WGSL default of `FEATURES`).
    pub const ALL: Features = Features(u64::MAX);

    /// The pipeline's override constants that say these features
    /// ([`FEATURES_CONSTANT`], [`FEATURES_HI_CONSTANT`]): each a u32,
    /// exact as f64.
    pub fn constants(self) -> [(&'static str, f64); 2] {
        [
            (FEATURES_CONSTANT, (self.0 & 0xffff_ffff) as f64),
            (FEATURES_HI_CONSTANT, (self.0 >> 32) as f64),
        ]
    }

    /// What `scene` uses: its primitive kinds, the kinds of its materials
    /// and textures (every one it lists), and its background's kind.
    pub fn of(scene: &Scene) -> Features {
        let mut bits = 0;
        for p in scene.primitives() {
            bits |= match p.tag {
                primitive_tag::SPHERE => feature::SPHERES,
                primitive_tag::QUAD => feature::QUADS,
                primitive_tag::TRIANGLE => feature::TRIANGLES,
                primitive_tag::QUADRIC => feature::QUADRICS,
                primitive_tag::SDF_VOXEL => feature::SDF_GRIDS,
                primitive_tag::INSTANCE => feature::INSTANCES,
                // A kind this list does not know: the general kernel.
                _ => u64::MAX,
            };
        }
        for m in scene.materials() {
            bits |= match m {
                Material::Lambertian { .. } => feature::LAMBERTIAN,
                Material::Metal { .. } => feature::METAL,
                Material::Dielectric { .. } => feature::DIELECTRIC,
                Material::Conductor { .. } => feature::CONDUCTOR,
                Material::SmoothDielectric { .. } => feature::SMOOTH_DIELECTRIC,
                Material::ThinDielectric { .. } => feature::THIN_DIELECTRIC,
                Material::RoughConductor {
                    distribution,
                    alpha_v,
                    ..
                } => feature::ROUGH_CONDUCTOR | beckmann(*distribution) | anisotropic(*alpha_v),
                Material::RoughDielectric {
                    distribution,
                    alpha_v,
                    ..
                } => feature::ROUGH_DIELECTRIC | beckmann(*distribution) | anisotropic(*alpha_v),
                Material::Plastic { .. } => feature::PLASTIC,
                Material::RoughPlastic { distribution, .. } => {
                    feature::ROUGH_PLASTIC | beckmann(*distribution)
                }
                Material::Principled { lobes, thin, .. } => {
                    let model = if *thin {
                        feature::PRINCIPLED_THIN
                    } else {
                        feature::PRINCIPLED
                    };
                    model | anisotropic(lobes.anisotropic)
                }
                Material::Ggx {
                    normal_map,
                    clearcoat,
                    ..
                } => {
                    let mut ggx = feature::GGX;
                    if normal_map.is_some() {
                        ggx |= feature::NORMAL_MAPS;
                    }
                    if clearcoat.is_some_and(|c| c.factor > 0.0) {
                        ggx |= feature::CLEARCOAT;
                    }
                    ggx
                }
                // Emission is read by tag, with no code of its own to drop.
                Material::DiffuseLight { .. } => 0,
            };
        }
        if (0..scene.materials().len() as u32).any(|m| scene.alpha(m).is_some()) {
            bits |= feature::ALPHA;
        }
        // Mitsuba's wrappers: the mask's draw and texture, the side test.
        for m in 0..scene.materials().len() as u32 {
            let w = scene.wrappers(m);
            if w.opacity.is_some() {
                bits |= feature::MASK;
            }
            if w.one_sided {
                bits |= feature::ONE_SIDED;
            }
            // Mitsuba's normal map reads the surface's tangent frame.
            if w.normal_map.is_some() {
                bits |= feature::TANGENT_FRAME;
            }
            // Mitsuba's blendbsdf: a second BSDF's textures and value.
            if w.blend.is_some() {
                bits |= feature::BLEND;
            }
        }
        // Emission added to a BSDF is one more texture read a vertex.
        if (0..scene.materials().len() as u32).any(|m| scene.added_emission(m).is_some()) {
            bits |= feature::EMISSIVE_BSDFS;
        }
        // Delta lights: a shadow ray even in the BSDF estimator.
        if !scene.punctual_lights().is_empty() {
            bits |= feature::PUNCTUAL_LIGHTS;
        }
        // Mitsuba's spot and projector: a profile read through the light's
        // frame, and maybe a texture.
        if scene
            .punctual_lights()
            .iter()
            .any(|l| l.tag == punctual_tag::SPOT_LINEAR || l.tag == punctual_tag::PROJECTOR)
        {
            bits |= feature::PROFILED_LIGHTS;
        }
        for t in scene.textures() {
            bits |= match t {
                Texture::Constant(_) => 0,
                Texture::Image { .. } => feature::IMAGE_TEXTURES,
                Texture::Checker { .. } => feature::CHECKER_TEXTURES,
                Texture::UvChecker { .. } => feature::UV_CHECKER_TEXTURES,
                Texture::VertexColor { .. } => feature::VERTEX_COLOR_TEXTURES,
            };
        }
        bits |= match scene.background() {
            Background::Solid(_) => feature::SOLID_BACKGROUND,
            Background::Sky { .. } => feature::SKY_BACKGROUND,
            Background::Envmap { .. } => feature::ENVMAP_BACKGROUND,
        };
        Features(bits)
    }

    pub fn contains(self, bits: u64) -> bool {
        self.0 & bits == bits
    }

    /// The names of the features set, for messages and the perf table.
    pub fn names(self) -> Vec<&'static str> {
        feature::NAMED
            .iter()
            .filter(|(_, bit)| self.contains(*bit))
            .map(|(name, _)| name.trim_start_matches("FEATURE_"))
            .collect()
    }
}

/// [`feature::BECKMANN`] for a microfacet model of Beckmann's
/// distribution, else nothing (GGX's code is the microfacets' baseline).
/// An anisotropic rough model reads the surface's tangent frame.
fn anisotropic(alpha_v: Option<u32>) -> u64 {
    if alpha_v.is_some() {
        feature::TANGENT_FRAME
    } else {
        0
    }
}

fn beckmann(distribution: u32) -> u64 {
    if distribution == reference::microfacet::distribution::BECKMANN {
        feature::BECKMANN
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bits_are_distinct_and_fit_the_constant() {
        let mut all = 0u64;
        for &(_, bit) in feature::NAMED {
            assert_eq!(bit.count_ones(), 1);
            assert_eq!(all & bit, 0, "bit {bit:#x} used twice");
            all |= bit;
        }
        // The WGSL constants are u32s passed as f64: exact.
        for (_, v) in Features::ALL.constants() {
            assert_eq!(v as u32, u32::MAX);
            assert_eq!(v as u32 as f64, v);
        }
    }

    #[test]
    fn the_cornell_box_uses_quads_lambertian_and_a_solid_background() {
        let scene = reference::load_scene("cornell").unwrap();
        let f = Features::of(&scene);
        assert_eq!(
            f.0,
            feature::QUADS | feature::LAMBERTIAN | feature::SOLID_BACKGROUND,
            "{:?}",
            f.names()
        );
    }
}
