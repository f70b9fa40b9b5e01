//! Mutation points: deliberate defects in the production code, switched on
//! only by the gates' own tests (tests/tools/gates_catch_mutants.rs), to prove
//! that some gate fails on each. Compiled in only with the cargo feature
//! `mutants`, which the workspace's integration tests enable; without it
//! [`active`] is the constant [`Mutant::None`] and every point folds away.
//!
//! A mutant is active on the threads of a pool made by [`pool`] (the
//! renderer's rayon tiles run there), so tests running beside it in the
//! same process see the production code unchanged.

/// One deliberate defect.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mutant {
    #[default]
    None,
    /// The metal lobe's weight ×0.95 (`material::scatter`).
    MetalWeight,
    /// The sphere's normal tilted 1.1° about the x axis
    /// (`Scene::surface_interaction`).
    SphereNormalTilt,
    /// The spawn nudge of Wächter & Binder, 256 ulps per unit of normal,
    /// in place of one float step (`geometry::offset_ray_origin`): a
    /// quarter unit at 9000, the far-from-origin defect it had.
    WideSpawnNudge,
    /// MIS: emission found by a BSDF sample counted in full although light
    /// sampling also counts it (the weights sum to 2; `integrator`).
    MisDoubleCount,
    /// The light's density in solid angle without `|cos θ_light|`
    /// (`light::LightSet::pdf`).
    LightPdfNoCosine,
    /// The light's area density used as if it were per solid angle
    /// (`light::LightSet::pdf`).
    LightPdfPerArea,
    /// The environment map's density in solid angle without the
    /// equirectangular Jacobian's `sin θ` (`light::EnvLight::pdf`).
    EnvPdfNoSinTheta,
    /// The four-wide leaf blocks accept a triangle's hit without asking
    /// its coverage (`scene::leaf`'s `LeafTests::intersect_leaf`).
    AlphaIgnoredInLeafBlocks,
    /// Render space left at the world's origin: a loaded scene is rounded
    /// to f32 where its file puts it (`SceneBuilder::build`; active on
    /// the thread that builds the scene: [`with`]).
    NoRenderSpace,
    /// The emission added to a material's BSDF dropped: such a material
    /// reflects only (`Scene::emission`, read by the integrators and the
    /// light set alike).
    AddedEmissionDropped,
    /// Schlick's Fresnel with `(1 − cos)⁴` for `(1 − cos)⁵`
    /// (`material::schlick_reflectance`, read by both estimators and the
    /// dielectric's sampling alike).
    SchlickFourthPower,
    /// A material with added emission loses its BSDF and only emits, as
    /// glTF's emissive materials did before emission was added to the
    /// BSDF (`integrator`'s `vertex_material`).
    EmissiveBsdfDropped,
    /// A punctual light's contribution without the receiver's `|cos θ|`
    /// (`integrator`'s `next_event`).
    PunctualNoCosine,
    /// A point or spot light falling off as `1/d` for `1/d²`
    /// (`light::PunctualLight::toward`).
    PunctualInverseDistance,
    /// A spot's falloff linear in its ramp, `t` for the glTF formula's
    /// `t²` (`light::PunctualLight::falloff`).
    SpotFalloffLinear,
    /// A punctual light's selection probability taken as uniform over the
    /// light set while lights are picked by power
    /// (`light::LightSet::punctual_pmf`).
    PunctualPmfUniform,
    /// A smooth dielectric's Fresnel reflectance with the ratio of the
    /// indices inverted (`material::fresnel_dielectric`).
    DielectricEtaInverted,
    /// A thin dielectric's reflectance without its inner reflections: the
    /// one interface's `F` for `2F / (1 + F)`
    /// (`material::thin_dielectric_reflectance`).
    ThinDielectricOneBounce,
    /// A conductor's `eta` and `k` exchanged in its Fresnel reflectance
    /// (`material::fresnel_conductor`).
    ConductorEtaKSwapped,
    /// The rough materials' microfacets Beckmann's where their scene asks
    /// for GGX (`material::scatter` and `material::bsdf_eval`).
    RoughBeckmannForGgx,
    /// An anisotropic rough model's two roughnesses exchanged: `alpha_v`
    /// along the surface's tangent and `alpha_u` across it
    /// (`material::rough_lobe`).
    AnisotropySwapped,
    /// The surface's tangent frame from its normal alone
    /// (`Onb::from_normal`), not from its parameterization's ∂p/∂u, where
    /// a normal map reads it (`material::NormalMapped::new`).
    TangentNotFromUv,
    /// A normal map's value without Estevez et al.'s shadowing term
    /// (`material::NormalMapped::shadowing`).
    NormalMapWithoutShadowing,
    /// A bump map's height gradient along v negated: its texture read as
    /// if v ran down the image as its rows do
    /// (`material::NormalMapped::bumped`).
    BumpGradientVFlipped,
    /// The rough conductor's density without the half vector's Jacobian
    /// `1 / (4 wo·h)`: the visible normals' density given as the reflected
    /// direction's (`material::bsdf_eval`).
    RoughPdfWithoutJacobian,
    /// Beckmann's visible slopes drawn without the viewer's
    /// foreshortening (the marginal CDF's `tan θ` term dropped): the
    /// distribution's normals, not the visible ones
    /// (`microfacet::beckmann_visible_slope`).
    BeckmannSlopesNotVisible,
    /// The rough dielectric's index ratio not inverted on its back face:
    /// light leaving the inside bends and reflects as if it entered
    /// (`material::scatter` and `material::bsdf_eval`).
    RoughDielectricEtaUninverted,
    /// The rough dielectric's transmission density without the refracted
    /// half vector's Jacobian `η²|wi·h| / (wo·h + η wi·h)²`
    /// (`material::bsdf_eval`).
    RoughTransmissionWithoutJacobian,
    /// The plastics' base without its coat's inner reflections: the
    /// diffuse reflectance for `diffuse / (1 − F_dr)`
    /// (`material::plastic_base`).
    PlasticInnerReflectionsDropped,
    /// The rough plastic's base without its coat's transmittance: `T` read
    /// as 1 at both crossings (`material::rough_plastic_eval`).
    RoughPlasticTransmittanceUnread,
    /// A one-sided material that reflects behind as in front (its
    /// [`crate::material::Wrappers::one_sided`] unread:
    /// `material::wrapped_scatter`, `material::wrapped_bsdf_eval`).
    OneSidedBackReflects,
    /// A mask's light samples weighed without its opacity: the material's
    /// value and density in full where the mask is partly open
    /// (`material::wrapped_bsdf_eval`).
    MaskLightUnscaled,
    /// A `blendbsdf` that weighs its first BSDF by the weight texture's
    /// value and its second by one minus it, the other way round from
    /// Mitsuba's (`material::Bsdf`).
    BlendWeightSwapped,
    /// The principled diffuse lobe without Burley's retro-reflection
    /// (`principled::Principled::eval`).
    PrincipledRetroDropped,
    /// The principled specular reflection's density without the half
    /// vector's Jacobian `1 / (4 wo·h)` (`principled::Principled::pdf`).
    PrincipledReflectionJacobianDropped,
    /// The thin principled sheet's specular transmission at the
    /// reflection's roughness, not scaled by `0.65·eta − 0.35`
    /// (`principled::Principled::thin_transmission`).
    PrincipledThinRoughnessUnscaled,
    /// Mitsuba's `null` BSDF read as an opaque black surface rather than
    /// one light passes straight through (`SceneBuilder::null_material`).
    NullOpaque,
    /// A Mitsuba `envmap` read without the half turn about +y that puts
    /// Mitsuba's u = 0 (along −z) where twintrace's is
    /// (`loader::mitsuba::scene`).
    MitsubaEnvmapNoHalfTurn,
    /// A Mitsuba emitter's uniform spectrum read as grey, as a
    /// reflectance's is, rather than as the equal-energy illuminant's
    /// colour (`loader::mitsuba::scene`, [`crate::loader::mitsuba::EQUAL_ENERGY_RGB`]).
    MitsubaIlluminantGrey,
    /// A Mitsuba `checkerboard` read at twintrace's texture coordinates
    /// (v up) rather than at Mitsuba's (v down) (`loader::mitsuba::scene`).
    MitsubaCheckerboardUnflipped,
    /// A Mitsuba `checkerboard` read as a number (a roughness) with its
    /// colours where Mitsuba's `eval` puts them rather than where its
    /// `eval_1` does (`loader::mitsuba::scene`).
    MitsubaCheckerboardNumberUnswapped,
    /// A Mitsuba `orthographic` sensor's window placed at the sensor's
    /// origin rather than at its near clip distance
    /// (`loader::mitsuba::scene`).
    MitsubaOrthographicNearIgnored,
    /// A Mitsuba film without an `rfilter` read with the box rather than
    /// Mitsuba's default Gaussian (`loader::mitsuba::scene`).
    MitsubaDefaultFilterBox,
    /// A PLY face attribute read as a vertex attribute: a corner takes the
    /// value of the face numbered as its vertex (`loader::mitsuba::scene`).
    MitsubaFaceAttributeByVertex,
    /// Mitsuba's spot ramped linearly in the cosine between its cutoff
    /// and beam width rather than in the angle (`light::PunctualLight`).
    SpotRampInCosine,
    /// Mitsuba's projector without its obliquity, `1 / q_z²` where
    /// Mitsuba has `1 / (q_z² cos θ)` (`light::PunctualLight`).
    ProjectorNoObliquity,
    /// A spot's or projector's texture read at Mitsuba's `(u, v)` as
    /// twintrace's coordinates, without the v flip
    /// (`light::PunctualLight`).
    LightTextureUnflipped,
    /// A quadric's texture coordinates left in Mitsuba's convention (v = 0
    /// at an image's top) instead of twintrace's
    /// (`shapes::Quadric::surface`).
    QuadricVUnflipped,
    /// A `cylinder` given by `p0` and `p1` placed with its frame's
    /// tangents swapped, not Mitsuba's `coordinate_system` (the Mitsuba
    /// reader): its uv turns by a quarter.
    CylinderFrameSwapped,
    /// A signed distance grid's smooth shading normal replaced by its
    /// geometric one (`sdf::SdfGrid::object_normals`).
    SdfSmoothNormalsIgnored,
    /// A grid cell's trilinear expansion with its xz and yz terms swapped
    /// (`sdf::cubic_along`).
    SdfCubicTermsSwapped,
    /// A cylinder's or a quadric sphere's light density from the point a
    /// direction meets first alone, not summed over both points it
    /// reaches (`light::LightSet::pdf`): its direct light counted up to
    /// twice.
    QuadricDensityOneCrossing,
    /// A Mitsuba `rotate`'s axis normalized, which Mitsuba 3 does not do
    /// (the Mitsuba reader's `rotation`).
    MitsubaRotateAxisNormalized,
    /// A mirroring instance's face normal left as its mapped triangle's
    /// (not turned back to the group's through the inverse transpose,
    /// `Scene::surface_interaction`): its faces point inward.
    InstanceMirrorIgnored,
    /// An instance's vertex normals mapped by the map's linear part, not
    /// its inverse transpose (`Scene::triangle_vertices`).
    InstanceNormalsByLinearPart,
}

#[cfg(feature = "mutants")]
thread_local! {
    static ACTIVE: std::cell::Cell<Mutant> = const { std::cell::Cell::new(Mutant::None) };
}

/// The mutant active on this thread.
#[inline(always)]
pub fn active() -> Mutant {
    #[cfg(feature = "mutants")]
    {
        ACTIVE.with(|a| a.get())
    }
    #[cfg(not(feature = "mutants"))]
    {
        Mutant::None
    }
}

/// Whether `m` is active on this thread.
#[inline(always)]
pub fn is(m: Mutant) -> bool {
    active() == m
}

/// A rayon pool whose threads run with `m` active: `pool(m).install(||
/// render(...))` renders the mutant with the production renderer.
#[cfg(feature = "mutants")]
pub fn pool(m: Mutant) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .start_handler(move |_| ACTIVE.with(|a| a.set(m)))
        .build()
        .expect("a rayon pool")
}

/// Runs `f` on this thread with `m` active (for single-threaded checks).
#[cfg(feature = "mutants")]
pub fn with<R>(m: Mutant, f: impl FnOnce() -> R) -> R {
    let before = ACTIVE.with(|a| a.replace(m));
    let r = f();
    ACTIVE.with(|a| a.set(before));
    r
}
