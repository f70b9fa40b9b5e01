//! The built scene ([`Scene`]): what an image means, immutable and always
//! valid, with its BVH and the traversal's copies of the geometry, and the
//! queries the twins make of it.

use super::leaf::{primitive_bounds, Accel, Coverage, Group, LeafPrim, Objects};
use super::primitive::{primitive_tag, Primitive};
use super::render_space::RenderSpace;
use super::settings::RenderSettings;
use crate::background::Background;
use crate::bvh::{Bvh, BvhBuildStats};
use crate::camera::{Camera, CameraSettings};
use crate::error::SceneError;
use crate::filter::{FilterTable, PixelFilter};
use crate::geometry::{gamma, tangent_frame, Aabb, Hit, Onb, Ray, SurfaceInteraction};
use crate::light::punctual::PunctualLight;
use crate::material::{alpha_hash, normal_mapped, Alpha, Material, Wrappers};
use crate::mutants::{self, Mutant};
use crate::sdf::{SdfGrid, SdfVoxel};
use crate::shapes::{
    mat_vec, Instance, MeshData, Quad, Quadric, Sphere, Triangle, TRIANGLE_HAS_ALPHA,
    TRIANGLE_HAS_COLORS, TRIANGLE_HAS_NORMALS, TRIANGLE_HAS_TANGENTS, TRIANGLE_HAS_UV1,
    TRIANGLE_HAS_UVS,
};
use crate::texture::{evaluate_texture, ImageData, Texture};
use glam::{DVec3, Vec2, Vec3, Vec4};
use std::f32::consts::PI;
use std::path::PathBuf;

/// A triangle hit's interpolated point, texture coordinates (both sets:
/// the barycentrics where the mesh has no uvs, zero where it has no second
/// set) and vertex colour (one where it has none).
struct TrianglePoint {
    p: Vec3,
    uvs: [Vec2; 2],
    color: Vec4,
}

/// A triangle's vertices as shading reads them
/// ([`Scene::triangle_vertices`]).
struct TriangleVertices {
    p: [Vec3; 3],
    n: [Vec3; 3],
    tangents: [Vec4; 3],
}

/// Whether an instance's map mirrors (its linear part's determinant, in
/// f32 as both twins compute it, is negative).
#[inline]
pub fn map_mirrors(map: &Quadric) -> bool {
    let [c0, c1, c2] = map.linear;
    c0.dot(c1.cross(c2)) < 0.0
}

/// A normal `n` through an instance's map: its inverse transpose (the
/// rows of the inverse are the columns `inv_linear`), not normalized.
#[inline]
pub fn inverse_transposed(map: &Quadric, n: Vec3) -> Vec3 {
    if mutants::is(Mutant::InstanceNormalsByLinearPart) {
        return mat_vec(&map.linear, n);
    }
    let inv = &map.inv_linear;
    Vec3::new(inv[0].dot(n), inv[1].dot(n), inv[2].dot(n))
}

/// A tangent through an instance's map: its direction by the linear
/// part, its handedness (`w`) turned where the map mirrors.
#[inline]
pub fn mapped_tangent(map: &Quadric, t: Vec4) -> Vec4 {
    let side = if map_mirrors(map) { -1.0 } else { 1.0 };
    mat_vec(&map.linear, t.truncate()).extend(side * t.w)
}

/// The error bound of an instance's vertex `o` (object space) once
/// mapped, a sum of three products and the origin: γ(5) times its terms'
/// largest sum, as a quadric's point (`Quadric::surface`).
#[inline]
pub fn instance_vertex_error(map: &Quadric, o: Vec3) -> f32 {
    let terms = (o.x * map.linear[0]).abs()
        + (o.y * map.linear[1]).abs()
        + (o.z * map.linear[2]).abs()
        + map.origin.abs();
    gamma(5) * terms.max_element()
}

/// Emitter selection by weights a scene file gives, as Mitsuba selects
/// an emitter with probability proportional to its `sampling_weight`
/// (default 1): a shape's weight is shared among its primitives by area
/// (so the shape is sampled uniformly by area, as Mitsuba's), an
/// emitting primitive of no listed shape weighs 1, and the environment
/// map and each punctual light weigh what is given (a solid background
/// is never a light, [`crate::light`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EmitterWeights {
    /// Emitting shapes: their primitive ids and weight.
    pub shapes: Vec<(std::ops::Range<u32>, f32)>,
    /// By punctual light, in the order they were added.
    pub punctual: Vec<f32>,
    /// The environment map's.
    pub environment: f32,
}

impl EmitterWeights {
    /// Checks the weights (finite, above 0, one a punctual light, ranges
    /// of existing primitives).
    pub(super) fn checked(self, primitives: usize, punctual: usize) -> Result<Self, SceneError> {
        let bad = |w: f32| !(w.is_finite() && w > 0.0);
        if self.punctual.len() != punctual {
            return Err(SceneError::invalid(
                "sampling_weight",
                format!(
                    "{} weights for {punctual} punctual lights",
                    self.punctual.len()
                ),
            ));
        }
        for &w in self.punctual.iter().chain([&self.environment]) {
            if bad(w) {
                return Err(SceneError::invalid(
                    "sampling_weight",
                    format!("{w} must be finite and above 0"),
                ));
            }
        }
        for (range, w) in &self.shapes {
            if bad(*w) || range.start > range.end || range.end as usize > primitives {
                return Err(SceneError::invalid(
                    "sampling_weight",
                    format!("weight {w} of primitives {range:?} (of {primitives})"),
                ));
            }
        }
        Ok(self)
    }
}

/// A validated scene with its BVH. Made only by [`super::SceneBuilder::build`],
/// or from another scene by [`Scene::edited`] and [`Scene::with_bvh`],
/// which check what they change as the builder does: the fields are
/// private, so a `Scene` is always valid and its traversal's copies of the
/// geometry always match it. Read through the accessors.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The scene's camera in world coordinates, as the file states it.
    pub(super) camera_settings: CameraSettings,
    /// The same camera in render space, placed from the file's f64 numbers.
    pub(super) render_camera: CameraSettings,
    /// Where render space lies: every position below is in it.
    pub(super) render_space: RenderSpace,
    pub(super) render: RenderSettings,
    /// How each pixel's camera samples are spread, and its sampling table
    /// (none for the box).
    pub(super) filter: PixelFilter,
    pub(super) filter_table: Option<std::sync::Arc<FilterTable>>,
    /// The file's emitter selection weights, if it gave them.
    pub(super) emitter_weights: Option<EmitterWeights>,
    pub(super) background: Background,
    pub(super) spheres: Vec<Sphere>,
    pub(super) quads: Vec<Quad>,
    pub(super) quadrics: Vec<Quadric>,
    pub(super) sdf_grids: Vec<SdfGrid>,
    pub(super) sdf_voxels: Vec<SdfVoxel>,
    pub(super) triangles: Vec<Triangle>,
    pub(super) mesh: MeshData,
    pub(super) materials: Vec<Material>,
    /// By material: its coverage, if it has one ([`Scene::alpha_covers`]).
    pub(super) alphas: Vec<Option<Alpha>>,
    /// By material: the texture of the emission added to its BSDF
    /// ([`super::SceneBuilder::set_emission`]), if it has one.
    pub(super) emissions: Vec<Option<u32>>,
    /// By material: Mitsuba's wrappers on it ([`super::SceneBuilder::set_wrappers`]).
    pub(super) wraps: Vec<Wrappers>,
    pub(super) textures: Vec<Texture>,
    pub(super) images: Vec<ImageData>,
    /// Point, spot and directional lights, positions in render space.
    pub(super) punctual_lights: Vec<PunctualLight>,
    /// All primitives in scene order; the index is the primitive id.
    pub(super) primitives: Vec<Primitive>,
    /// Instanced groups: triangles kept once in object space, each with
    /// its own tree (the second level), drawn by `instances`.
    pub(super) groups: Vec<Group>,
    /// Placements of `groups`, each a primitive of the scene's own tree.
    pub(super) instances: Vec<Instance>,
    /// The BVH over `primitives` with the traversal's copies of their
    /// geometry in its leaf order (made by [`Scene::put_bvh`]).
    pub(super) accel: Accel,
    /// What [`super::SceneBuilder::build`]'s BVH build reported.
    pub(super) bvh_stats: BvhBuildStats,
    /// What the loaders ignored ([`super::SceneBuilder::warnings`]).
    pub(super) warnings: Vec<String>,
    /// The files the scene was read from ([`super::SceneBuilder::sources`]).
    pub(super) sources: Vec<PathBuf>,
}

/// A 64-bit FNV-1a hash over 32-bit words (and the bytes of text):
/// [`Scene::fingerprint`]'s. Not a cryptographic hash: it tells apart
/// scenes that differ by mistake, not by design.
struct Fingerprint(u64);

impl Fingerprint {
    const PRIME: u64 = 0x0000_0100_0000_01b3;

    fn word(&mut self, w: u32) {
        self.0 = (self.0 ^ w as u64).wrapping_mul(Self::PRIME);
    }

    fn floats(&mut self, values: impl IntoIterator<Item = f32>) {
        for v in values {
            self.word(v.to_bits());
        }
    }
}

impl std::fmt::Write for Fingerprint {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        for b in s.bytes() {
            self.word(b as u32);
        }
        Ok(())
    }
}

impl Scene {
    /// A fingerprint of everything that decides what the scene renders
    /// (camera, background, shapes, vertex data, materials and their
    /// coverage, textures, image texels; the scene's own render settings
    /// are not in it): partial renders of one scene carry it, so that
    /// parts of different scenes are not merged. Floats enter by their
    /// bits (through `Debug`, which prints every f32 so that it reads back
    /// to the same bits, for the small structured parts).
    pub fn fingerprint(&self) -> u64 {
        use std::fmt::Write;
        let mut h = Fingerprint(0xcbf2_9ce4_8422_2325);
        let _ = write!(
            h,
            "{:?}{:?}{:?}{:?}{:?}{:?}{:?}{:?}",
            self.camera_settings,
            self.render_camera,
            self.background,
            self.materials,
            self.alphas,
            self.emissions,
            self.textures,
            self.punctual_lights
        );
        // Only where a material has one, so that scenes without keep
        // their fingerprints.
        if self.wraps.iter().any(|w| *w != Wrappers::default()) {
            let _ = write!(h, "{:?}", self.wraps);
        }
        if let Some(w) = &self.emitter_weights {
            let _ = write!(h, "{w:?}");
        }
        for c in self.render_space.origin().to_array() {
            let bits = c.to_bits();
            h.word(bits as u32);
            h.word((bits >> 32) as u32);
        }
        for s in &self.spheres {
            let _ = write!(h, "{s:?}");
        }
        for q in &self.quads {
            let _ = write!(h, "{q:?}");
        }
        for q in &self.quadrics {
            let _ = write!(h, "{q:?}");
        }
        for g in &self.sdf_grids {
            let _ = write!(h, "{:?}{:?}{:?}{}", g.map, g.map_f64, g.dims, g.smooth);
            h.floats(g.values.iter().copied());
        }
        for t in &self.triangles {
            let _ = write!(h, "{t:?}");
        }
        // Only where there are instances, so that scenes without keep
        // their fingerprints.
        for g in &self.groups {
            let _ = write!(h, "{:?}", g.triangles);
        }
        for i in &self.instances {
            let _ = write!(h, "{i:?}");
        }
        let m = &self.mesh;
        h.floats(
            m.positions
                .iter()
                .chain(&m.normals)
                .flat_map(|v| v.to_array()),
        );
        h.floats(m.uvs.iter().chain(&m.uvs1).flat_map(|v| v.to_array()));
        h.floats(
            m.colors
                .iter()
                .chain(&m.tangents)
                .flat_map(|v| v.to_array()),
        );
        for image in &self.images {
            h.word(image.width);
            h.word(image.height);
            h.floats(image.texels.iter().flat_map(|t| t.to_array()));
        }
        h.0
    }

    /// What the loaders ignored and the user should hear of, one line each
    /// (e.g. glTF extensions the importer does not support and the file
    /// does not require).
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// The files the loaders read to make the scene, each once, as they
    /// named them (relative paths joined to the folder of the file that
    /// names them): the scene file, its glTF documents and their external
    /// buffers and images, meshes and image textures. Empty for a
    /// built-in scene. A command that writes files refuses an output
    /// naming one of them.
    pub fn sources(&self) -> &[PathBuf] {
        &self.sources
    }

    /// The scene's camera for an image of `width x height`, in render
    /// space (what the twins trace).
    pub fn camera(&self, width: u32, height: u32) -> Camera {
        Camera::new(&self.render_camera, width as f32 / height as f32)
    }

    /// The camera as the scene describes it, in world coordinates (what
    /// tools show and save; [`Scene::render_camera_of`] takes it into
    /// render space).
    pub fn camera_settings(&self) -> CameraSettings {
        self.camera_settings
    }

    /// How each pixel's camera samples are spread.
    pub fn filter(&self) -> PixelFilter {
        self.filter
    }

    /// The filter's sampling table (none for the box).
    pub fn filter_table(&self) -> Option<&FilterTable> {
        self.filter_table.as_deref()
    }

    /// The scene's own camera in render space.
    pub fn render_camera_settings(&self) -> CameraSettings {
        self.render_camera
    }

    /// A camera given in world coordinates, in render space: its position
    /// and target translated in f64 and rounded; the scene's own camera
    /// (equal field for field) is the one the file's f64 numbers placed.
    /// Every camera a render traces goes through here
    /// ([`Self::traced_camera`]).
    pub fn render_camera_of(&self, world: &CameraSettings) -> CameraSettings {
        if *world == self.camera_settings {
            return self.render_camera;
        }
        CameraSettings {
            look_from: self.to_render(world.look_from.as_dvec3()),
            look_at: self.to_render(world.look_at.as_dvec3()),
            ..*world
        }
    }

    /// The camera a render with `settings` sees this scene from, in world
    /// coordinates (what tools show and save): the settings' own, else the
    /// scene's.
    pub fn camera_settings_for(&self, settings: &RenderSettings) -> CameraSettings {
        settings.camera.unwrap_or(self.camera_settings())
    }

    /// [`Self::camera_settings_for`] in render space
    /// ([`Self::render_camera_of`]), ready for an image of the settings'
    /// size: the camera both twins trace.
    pub fn traced_camera(&self, settings: &RenderSettings) -> Camera {
        let traced = match &settings.camera {
            Some(world) => self.render_camera_of(world),
            None => self.render_camera_settings(),
        };
        Camera::new(&traced, settings.width as f32 / settings.height as f32)
    }

    /// Where render space lies (its origin in world coordinates and the
    /// checkers' lattice).
    pub fn render_space(&self) -> RenderSpace {
        self.render_space
    }

    /// World coordinates of render space's origin: a world point is
    /// `render-space point + render_origin()`.
    pub fn render_origin(&self) -> DVec3 {
        self.render_space.origin()
    }

    /// A world point in render space (translated in f64, rounded to f32).
    pub fn to_render(&self, world: DVec3) -> Vec3 {
        (world - self.render_space.origin()).as_vec3()
    }

    /// A render-space point in world coordinates (exact in f64).
    pub fn to_world(&self, render: Vec3) -> DVec3 {
        render.as_dvec3() + self.render_space.origin()
    }

    /// The scene's render defaults (size, spp, depth, seed, roulette), which
    /// a render's own settings may override.
    pub fn render_settings(&self) -> RenderSettings {
        self.render
    }

    /// The emitter selection weights the scene's file gave (Mitsuba's
    /// `sampling_weight`s), or `None`: by power ([`crate::light`]).
    pub fn emitter_weights(&self) -> Option<&EmitterWeights> {
        self.emitter_weights.as_ref()
    }

    pub fn background(&self) -> Background {
        self.background
    }

    pub fn spheres(&self) -> &[Sphere] {
        &self.spheres
    }

    pub fn quads(&self) -> &[Quad] {
        &self.quads
    }

    /// The disks, cylinders and Mitsuba-textured spheres.
    pub fn quadrics(&self) -> &[Quadric] {
        &self.quadrics
    }

    /// The signed distance grids ([`crate::sdf`]).
    pub fn sdf_grids(&self) -> &[SdfGrid] {
        &self.sdf_grids
    }

    /// The grids' cells the surface may cross: the primitives of tag
    /// `SDF_VOXEL` index this list.
    pub fn sdf_voxels(&self) -> &[SdfVoxel] {
        &self.sdf_voxels
    }

    /// What a leaf entry reads through an index: quadrics and grids.
    /// Instanced groups (Mitsuba's `shapegroup`s): their triangles, kept
    /// once in object space, and their trees.
    pub fn groups(&self) -> &[Group] {
        &self.groups
    }

    /// Placements of [`Scene::groups`] (each a primitive of tag
    /// `INSTANCE`).
    pub fn instances(&self) -> &[Instance] {
        &self.instances
    }

    pub(super) fn objects(&self) -> Objects<'_> {
        Objects {
            quadrics: &self.quadrics,
            grids: &self.sdf_grids,
            voxels: &self.sdf_voxels,
            instances: &self.instances,
        }
    }

    pub fn triangles(&self) -> &[Triangle] {
        &self.triangles
    }

    /// The vertices the triangles index.
    pub fn mesh(&self) -> &MeshData {
        &self.mesh
    }

    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// Material `material`'s coverage, if it has one.
    pub fn alpha(&self, material: u32) -> Option<Alpha> {
        self.alphas.get(material as usize).copied().flatten()
    }

    /// Mitsuba's wrappers on material `material` (the default where it has
    /// none).
    pub fn wrappers(&self, material: u32) -> Wrappers {
        self.wraps
            .get(material as usize)
            .copied()
            .unwrap_or_default()
    }

    /// The texture of what material `material` emits from its front
    /// face, if it emits: a `DiffuseLight`'s emission, or the emission
    /// added to another material's BSDF ([`Scene::added_emission`]).
    pub fn emission(&self, material: u32) -> Option<u32> {
        match self.materials.get(material as usize)? {
            Material::DiffuseLight { emission } => Some(*emission),
            _ if mutants::is(Mutant::AddedEmissionDropped) => None,
            _ => self.added_emission(material),
        }
    }

    /// The texture of the emission added to material `material`'s BSDF
    /// (glTF's emission on a metallic-roughness material, the JSON's
    /// `emission` on any material but `diffuse_light`), if it has one. A
    /// `DiffuseLight` has none: what it emits is its own (a material
    /// that [`Scene::edited`] made one emits only that).
    pub fn added_emission(&self, material: u32) -> Option<u32> {
        match self.materials.get(material as usize)? {
            Material::DiffuseLight { .. } => None,
            _ => self.emissions.get(material as usize).copied().flatten(),
        }
    }

    pub fn textures(&self) -> &[Texture] {
        &self.textures
    }

    /// The point, spot and directional lights (positions in render space).
    pub fn punctual_lights(&self) -> &[PunctualLight] {
        &self.punctual_lights
    }

    pub fn images(&self) -> &[ImageData] {
        &self.images
    }

    /// All primitives in scene order; the index is the primitive id.
    pub fn primitives(&self) -> &[Primitive] {
        &self.primitives
    }

    /// The BVH over `primitives` (what the GPU uploads).
    pub fn bvh(&self) -> &Bvh {
        &self.accel.bvh
    }

    /// What [`super::SceneBuilder::build`]'s BVH build reported.
    pub fn bvh_stats(&self) -> BvhBuildStats {
        self.bvh_stats
    }

    /// Installs `bvh` and copies the geometry into its leaf order. The
    /// caller has checked that `bvh` indexes only primitives of this scene.
    pub(super) fn put_bvh(&mut self, bvh: Bvh) {
        self.accel = Accel::new(bvh, |prim| self.leaf_prim(prim));
    }

    /// The bounds of every primitive in render space (where rays are
    /// aimed); [`Scene::to_world`] takes its corners to world coordinates.
    pub fn bounds(&self) -> Aabb {
        self.accel
            .bvh
            .nodes()
            .first()
            .map(|n| n.bounds())
            .unwrap_or(Aabb::EMPTY)
    }

    /// The bounding box of one primitive (by id), as the BVH build saw it.
    #[inline]
    pub fn primitive_bounds(&self, prim: u32) -> Aabb {
        primitive_bounds(
            self.primitives[prim as usize],
            &self.spheres,
            &self.quads,
            self.objects(),
            &self.triangles,
            &self.mesh,
        )
    }

    /// Intersects one primitive (by id). A hit counts only where the
    /// primitive's own box passes the traversal's box test up to the hit
    /// ([`Bvh::admits`]): that is what makes the BVH and the brute-force
    /// scan agree bit for bit.
    #[inline]
    pub fn intersect_primitive(&self, prim: u32, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let leaf = self.leaf_prim(prim);
        let k = self.accel.constants(ray)?;
        let hit = leaf.intersect(ray, &k, self.objects(), self, t_min, t_max)?;
        (!leaf.has_alpha() || self.alpha_covers(ray, &hit)).then_some(hit)
    }

    /// Primitive `prim`'s entry of the traversal's copy of the geometry
    /// ([`LeafPrim`]).
    fn leaf_prim(&self, prim: u32) -> LeafPrim {
        let p = self.primitives[prim as usize];
        let geometry = match p.tag {
            primitive_tag::SPHERE => {
                let s = &self.spheres[p.index as usize];
                [s.center, Vec3::new(s.radius, 0.0, 0.0), Vec3::ZERO]
            }
            primitive_tag::QUAD => {
                let q = &self.quads[p.index as usize];
                [q.corner, q.u, q.v]
            }
            primitive_tag::QUADRIC | primitive_tag::SDF_VOXEL | primitive_tag::INSTANCE => {
                let b = self.primitive_bounds(prim);
                [b.min, b.max, Vec3::new(f32::from_bits(p.index), 0.0, 0.0)]
            }
            _ => self.triangles[p.index as usize]
                .vertices
                .map(|i| self.mesh.positions[i as usize]),
        };
        let alpha = p.tag == primitive_tag::TRIANGLE
            && self.triangles[p.index as usize].flags & TRIANGLE_HAS_ALPHA != 0;
        LeafPrim::new(prim, p.tag, geometry, alpha)
    }

    /// Closest hit in `(t_min, t_max)`, through the BVH. Leaves read the
    /// leaf-ordered copies in `leaf_prims`.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        self.accel
            .intersect(ray, t_min, t_max, self.objects(), self)
    }

    /// Closest hit by testing every primitive (and every triangle of an
    /// instance's group): the oracle for the BVH. Ties in t go to the
    /// smaller primitive id, as in the BVH traversal. Reads the scene's
    /// own arrays, not the traversal's copies.
    pub fn intersect_brute_force(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let c = self.accel.constants(ray)?;
        let mut best: Option<Hit> = None;
        let brute = BruteForce(self);
        for prim in 0..self.primitives.len() as u32 {
            let leaf = self.leaf_prim(prim);
            if let Some(h) = leaf.intersect(ray, &c, self.objects(), &brute, t_min, t_max) {
                let covered = !leaf.has_alpha() || self.alpha_covers(ray, &h);
                if covered && best.is_none_or(|b| h.t < b.t) {
                    best = Some(h);
                }
            }
        }
        best
    }

    /// Instance `index`'s hit: its group's closest hit on the ray mapped
    /// into object space (the same `t`), by the group's tree where
    /// `brute` is false, else by testing each triangle.
    fn instance_hit_by(
        &self,
        index: u32,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        brute: bool,
    ) -> Option<Hit> {
        let instance = &self.instances[index as usize];
        let group = &self.groups[instance.group as usize];
        let local = instance.map.object_ray(ray);
        let inner = InstanceTests;
        if !brute {
            return group
                .accel
                .intersect(&local, t_min, t_max, self.objects(), &inner);
        }
        let c = group.accel.constants(&local)?;
        let mut best: Option<Hit> = None;
        for tri in group.triangles.clone() {
            let leaf = self.group_leaf_prim(tri);
            if let Some(h) = leaf.intersect(&local, &c, self.objects(), &inner, t_min, t_max) {
                if best.is_none_or(|b| h.t < b.t) {
                    best = Some(h);
                }
            }
        }
        best
    }

    /// Triangle `tri` of a group as its tree's leaves hold it (its
    /// object-space vertices; `prim` the triangle's index).
    pub(super) fn group_leaf_prim(&self, tri: u32) -> LeafPrim {
        let vertices = self.triangles[tri as usize]
            .vertices
            .map(|i| self.mesh.positions[i as usize]);
        LeafPrim::new(tri, primitive_tag::TRIANGLE, vertices, false)
    }

    /// Whether the surface covers the point `hit` found on `ray`: false
    /// only on a triangle whose material has an alpha
    /// ([`TRIANGLE_HAS_ALPHA`]) that does not cover it there (the alpha
    /// texture at the hit's texture coordinates, as
    /// [`Scene::surface_interaction`] interpolates them, times the vertex
    /// colour's alpha). Every traversal asks this where it accepts a hit.
    #[inline]
    pub fn alpha_covers(&self, ray: &Ray, hit: &Hit) -> bool {
        let p = self.primitives[hit.prim as usize];
        if p.tag != primitive_tag::TRIANGLE {
            return true;
        }
        let tri = &self.triangles[p.index as usize];
        let Some(alpha) = self
            .alpha(tri.material)
            .filter(|_| tri.flags & TRIANGLE_HAS_ALPHA != 0)
        else {
            return true;
        };
        let at = self.triangle_point(tri, &self.triangle_vertices(tri, None).p, hit);
        let a = evaluate_texture(
            &self.textures,
            &self.images,
            alpha.texture,
            at.p,
            at.uvs,
            at.color.truncate(),
        )
        .x;
        alpha.covers(a * at.color.w, alpha_hash(ray, hit.prim))
    }

    /// Triangle `tri`'s vertices as shading reads them: positions, normals
    /// and tangents as stored (in render space), or, for a triangle of an
    /// instanced group, mapped by the instance's `map` from the group's
    /// object space: a position by the map, a normal by its inverse
    /// transpose (not normalized: [`Scene::surface_interaction`]
    /// normalizes what it interpolates), a tangent's direction by its
    /// linear part (its handedness turned where the map mirrors).
    #[inline]
    fn triangle_vertices(&self, tri: &Triangle, map: Option<&Quadric>) -> TriangleVertices {
        let m = &self.mesh;
        let [i0, i1, i2] = tri.vertices.map(|i| i as usize);
        let (p, n, t) = (
            [m.positions[i0], m.positions[i1], m.positions[i2]],
            [m.normals[i0], m.normals[i1], m.normals[i2]],
            [i0, i1, i2].map(|i| m.tangents.get(i).copied().unwrap_or(Vec4::ZERO)),
        );
        let Some(map) = map else {
            return TriangleVertices { p, n, tangents: t };
        };
        TriangleVertices {
            p: p.map(|p| map.to_world(p)),
            n: n.map(|n| inverse_transposed(map, n)),
            tangents: t.map(|t| mapped_tangent(map, t)),
        }
    }

    /// What a hit on triangle `tri` (of vertices `p`, [`Scene::triangle_vertices`]) interpolates for texturing, as both
    /// [`Scene::surface_interaction`] and [`Scene::alpha_covers`] read it.
    #[inline]
    fn triangle_point(&self, tri: &Triangle, p: &[Vec3; 3], hit: &Hit) -> TrianglePoint {
        let [i0, i1, i2] = tri.vertices.map(|i| i as usize);
        let m = &self.mesh;
        let (b1, b2) = (hit.uv.x, hit.uv.y);
        let b0 = 1.0 - b1 - b2;
        let uv = if tri.flags & TRIANGLE_HAS_UVS != 0 {
            b0 * m.uvs[i0] + b1 * m.uvs[i1] + b2 * m.uvs[i2]
        } else {
            hit.uv
        };
        let uv1 = if tri.flags & TRIANGLE_HAS_UV1 != 0 {
            b0 * m.uvs1[i0] + b1 * m.uvs1[i1] + b2 * m.uvs1[i2]
        } else {
            Vec2::ZERO
        };
        let color = if tri.flags & TRIANGLE_HAS_COLORS != 0 {
            b0 * m.colors[i0] + b1 * m.colors[i1] + b2 * m.colors[i2]
        } else {
            Vec4::ONE
        };
        TrianglePoint {
            p: b0 * p[0] + b1 * p[1] + b2 * p[2],
            uvs: [uv, uv1],
            color,
        }
    }

    /// Everything shading needs about a hit.
    pub fn surface_interaction(&self, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        let p = self.primitives[hit.prim as usize];
        let (mut uv1, mut color) = (Vec2::ZERO, Vec3::ONE);
        // Each shape's normal before the flip onto the geometric side,
        // ∂p/∂u's direction for the tangent frame, and ∂p/∂u and ∂p/∂v per
        // unit of uv for a bump map.
        let (pos, ng, ns, uv, material, p_error, frame_n, dp_du, dp_duv) = match p.tag {
            primitive_tag::SPHERE => {
                let s = &self.spheres[p.index as usize];
                let outward = (ray.at(hit.t) - s.center) / s.radius.abs();
                let outward = outward.normalize_or(Vec3::Y);
                // Re-project onto the surface (pbrt-v4 does the same): the
                // hit point then carries only a few ulps of error.
                let pos = s.center + s.radius.abs() * outward;
                let mut n = if s.radius < 0.0 { -outward } else { outward };
                if mutants::is(Mutant::SphereNormalTilt) {
                    n = glam::Quat::from_rotation_x(1.1f32.to_radians()) * n;
                }
                let uv = Vec2::new(
                    ((-outward.z).atan2(outward.x) + PI) / (2.0 * PI),
                    (-outward.y).clamp(-1.0, 1.0).acos() / PI,
                );
                // r·n̂ carries a few ulps of r (normalize, scale), the sum
                // with the centre a few ulps of the result.
                let err = gamma(5)
                    * (s.radius.abs() + s.center.abs().max_element() + pos.abs().max_element());
                // u grows with the angle atan2(-z, x) about +y.
                let dp_du = Vec3::new(outward.z, 0.0, -outward.x);
                let dp_duv = sphere_dp_duv(outward, s.radius.abs());
                (pos, n, n, uv, s.material, err, n, dp_du, dp_duv)
            }
            primitive_tag::QUADRIC => {
                let q = &self.quadrics[p.index as usize];
                let s = q.surface(ray, hit.t);
                (
                    s.p,
                    s.n,
                    s.n,
                    s.uv,
                    q.material,
                    s.p_error,
                    s.n,
                    s.dp_du,
                    (s.dp_du, s.dp_dv),
                )
            }
            primitive_tag::SDF_VOXEL => {
                let g = &self.sdf_grids[self.sdf_voxels[p.index as usize].grid as usize];
                let s = g.surface(ray, hit.t);
                // The smooth normal within a few degrees of the gradient:
                // on its side (as a mesh's interpolated normal).
                let ns = if s.shading_n.dot(s.n) < 0.0 {
                    -s.shading_n
                } else {
                    s.shading_n
                };
                // Mitsuba's uv (0, 0), v flipped into twintrace's; no
                // ∂p/∂u: the tangent frame is the normal's own.
                let uv = Vec2::new(0.0, 1.0);
                (
                    s.p,
                    s.n,
                    ns,
                    uv,
                    g.map.material,
                    s.p_error,
                    ns,
                    Vec3::ZERO,
                    (Vec3::ZERO, Vec3::ZERO),
                )
            }
            primitive_tag::QUAD => {
                let q = &self.quads[p.index as usize];
                let n = q.normal();
                let pos = q.corner + hit.uv.x * q.u + hit.uv.y * q.v;
                let err = gamma(4)
                    * (q.corner.abs()
                        + (hit.uv.x * q.u).abs()
                        + (hit.uv.y * q.v).abs()
                        + pos.abs())
                    .max_element();
                (pos, n, n, hit.uv, q.material, err, n, q.u, (q.u, q.v))
            }
            _ => {
                // A triangle of the scene, or one of an instance's group
                // seen through the instance's map.
                let (tri, map) = if p.tag == primitive_tag::INSTANCE {
                    let instance = &self.instances[p.index as usize];
                    (&self.triangles[hit.sub as usize], Some(&instance.map))
                } else {
                    (&self.triangles[p.index as usize], None)
                };
                let v = self.triangle_vertices(tri, map);
                let (b1, b2) = (hit.uv.x, hit.uv.y);
                let b0 = 1.0 - b1 - b2;
                let at = self.triangle_point(tri, &v.p, hit);
                let pos = at.p;
                // pbrt-v4's bound for barycentric interpolation, and for
                // an instance the error of its mapped vertices (as a
                // quadric's point, `Quadric::surface`).
                let mut err = gamma(7)
                    * ((b0 * v.p[0]).abs() + (b1 * v.p[1]).abs() + (b2 * v.p[2]).abs())
                        .max_element();
                if let Some(map) = map {
                    for i in tri.vertices {
                        err += instance_vertex_error(map, self.mesh.positions[i as usize]);
                    }
                }
                // An instance's face normal is its group's turned by the
                // map's inverse transpose (Mitsuba's instance): the mapped
                // edges' cross product, turned back where the map mirrors.
                let mut ng = (v.p[1] - v.p[0])
                    .cross(v.p[2] - v.p[0])
                    .normalize_or(Vec3::Y);
                if map.is_some_and(map_mirrors) && !mutants::is(Mutant::InstanceMirrorIgnored) {
                    ng = -ng;
                }
                // The interpolated normal, and the flip that puts it on
                // the geometric normal's side.
                let (mut n, mut side) = (ng, 1.0);
                if tri.flags & TRIANGLE_HAS_NORMALS != 0 {
                    n = (b0 * v.n[0] + b1 * v.n[1] + b2 * v.n[2]).normalize_or(ng);
                    side = if n.dot(ng) < 0.0 { -1.0 } else { 1.0 };
                }
                let [uv, second] = at.uvs;
                uv1 = second;
                color = at.color.truncate();
                let mut ns = side * n;
                if let (
                    true,
                    Material::Ggx {
                        normal_map: Some(map),
                        ..
                    },
                ) = (
                    tri.flags & TRIANGLE_HAS_TANGENTS != 0,
                    self.materials[tri.material as usize],
                ) {
                    let t = &v.tangents;
                    let tangent = b0 * t[0] + b1 * t[1] + b2 * t[2];
                    let texel = evaluate_texture(
                        &self.textures,
                        &self.images,
                        map.texture,
                        pos,
                        at.uvs,
                        at.color.truncate(),
                    );
                    ns = normal_mapped(n, side, ng, tangent, texel, map.scale);
                }
                let dp_duv = self.triangle_dp_duv_at(tri, &v.p, ng);
                (
                    pos,
                    ng,
                    ns,
                    uv,
                    tri.material,
                    err,
                    side * ns,
                    dp_duv.0,
                    dp_duv,
                )
            }
        };
        let (tangent, bitangent) = tangent_frame(frame_n, dp_du);
        SurfaceInteraction {
            p: pos,
            geometric_normal: ng,
            shading_normal: ns,
            uv,
            uv1,
            color,
            p_error,
            front_face: ray.direction.dot(ng) < 0.0,
            material,
            tangent,
            bitangent,
            dp_du: dp_duv.0,
            dp_dv: dp_duv.1,
        }
    }

    /// ∂p/∂u and ∂p/∂v of triangle `tri` of face normal `ng`, as Mitsuba's
    /// meshes give them: from the vertices' texture coordinates where it
    /// has them (where they are degenerate, [`Onb::from_normal`]'s
    /// tangent and bitangent of `ng`), else the edges `p1 − p0` and
    /// `p2 − p0` (u and v the barycentrics `b1`, `b2`).
    #[inline]
    pub fn triangle_dp_duv(&self, tri: &Triangle, ng: Vec3) -> (Vec3, Vec3) {
        self.triangle_dp_duv_at(tri, &self.triangle_vertices(tri, None).p, ng)
    }

    /// [`Scene::triangle_dp_duv`] with the triangle's vertices at `p`.
    #[inline]
    fn triangle_dp_duv_at(&self, tri: &Triangle, p: &[Vec3; 3], ng: Vec3) -> (Vec3, Vec3) {
        let [i0, i1, i2] = tri.vertices.map(|i| i as usize);
        let m = &self.mesh;
        let (dp0, dp1) = (p[1] - p[0], p[2] - p[0]);
        if tri.flags & TRIANGLE_HAS_UVS == 0 {
            return (dp0, dp1);
        }
        let (duv0, duv1) = (m.uvs[i1] - m.uvs[i0], m.uvs[i2] - m.uvs[i0]);
        let det = duv0.x * duv1.y - duv0.y * duv1.x;
        if det == 0.0 {
            let f = Onb::from_normal(ng);
            return (f.s, f.t);
        }
        (
            (duv1.y * dp0 - duv0.y * dp1) / det,
            (duv0.x * dp1 - duv1.x * dp0) / det,
        )
    }
}

/// ∂p/∂u and ∂p/∂v per unit of uv on a sphere of radius `r` at the unit
/// direction `o` from its centre, for its uv (u = (atan2(−z, x) + π) / 2π,
/// v = acos(−y) / π): u turns the point about +y, `2π·r·(o.z, 0, −o.x)`;
/// v moves it from the −y pole to the +y pole, `π·r·(−o.y·o.x/ρ, ρ,
/// −o.y·o.z/ρ)` with `ρ = √(o.x² + o.z²)` (along +y at the poles).
#[inline]
pub fn sphere_dp_duv(o: Vec3, r: f32) -> (Vec3, Vec3) {
    let rho = (o.x * o.x + o.z * o.z).sqrt();
    let dp_du = (2.0 * PI * r) * Vec3::new(o.z, 0.0, -o.x);
    let dp_dv = if rho > 0.0 {
        (PI * r) * Vec3::new(-o.y * o.x / rho, rho, -o.y * o.z / rho)
    } else {
        Vec3::new(0.0, PI * r, 0.0)
    };
    (dp_du, dp_dv)
}

impl Coverage for Scene {
    #[inline]
    fn covers(&self, ray: &Ray, hit: &Hit) -> bool {
        self.alpha_covers(ray, hit)
    }

    #[inline]
    fn instance_hit(&self, index: u32, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        self.instance_hit_by(index, ray, t_min, t_max, false)
    }
}

/// The brute-force oracle's leaf tests: an instance's group is scanned
/// triangle by triangle too.
struct BruteForce<'a>(&'a Scene);

impl Coverage for BruteForce<'_> {
    fn covers(&self, ray: &Ray, hit: &Hit) -> bool {
        self.0.alpha_covers(ray, hit)
    }

    fn instance_hit(&self, index: u32, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        self.0.instance_hit_by(index, ray, t_min, t_max, true)
    }
}

/// The leaf tests within a group: its triangles have no alpha (the
/// builder refuses one) and a group holds no instance.
struct InstanceTests;

impl Coverage for InstanceTests {
    #[inline]
    fn covers(&self, _: &Ray, _: &Hit) -> bool {
        true
    }

    #[inline]
    fn instance_hit(&self, _: u32, _: &Ray, _: f32, _: f32) -> Option<Hit> {
        None
    }
}
