//! The scene: what an image means. Built through [`SceneBuilder`], which
//! validates every parameter and builds the BVH; a `Scene` is immutable
//! and always valid.

use crate::background::Background;
use crate::bvh::{
    box_pad, intersect_aabb_padded, intersect_entries, Bvh, BvhBuildStats, Closest, LeafRef,
    Leaves, LEAF_BATCH,
};
use crate::camera::{Camera, CameraSettings};
use crate::error::SceneError;
use crate::geometry::{gamma, Aabb, Hit, Ray, SurfaceInteraction};
use crate::material::Material;
use crate::mutants::{self, Mutant};
use crate::shapes::{
    intersect_triangles4, MeshData, Quad, RayShear, Sphere, Triangle, Triangles4,
    TRIANGLE_HAS_NORMALS, TRIANGLE_HAS_UVS,
};
use crate::texture::{ImageData, Texture};
use glam::{Affine3A, Mat3, Quat, Vec2, Vec3};
use std::f32::consts::PI;

/// Numeric tags of primitive kinds, shared with the GPU.
pub mod primitive_tag {
    pub const SPHERE: u32 = 0;
    pub const QUAD: u32 = 1;
    pub const TRIANGLE: u32 = 2;
}

/// One entry of the scene's primitive list: a kind and an index into that
/// kind's array. The position in `Scene::primitives` is the primitive id.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Primitive {
    pub tag: u32,
    pub index: u32,
}

/// Render parameters a scene proposes; the command line overrides them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub max_depth: u32,
    pub seed: u32,
    /// Path vertex index from which Russian roulette may end paths.
    pub roulette_depth: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 400,
            height: 300,
            spp: 64,
            max_depth: 16,
            seed: 0,
            roulette_depth: 3,
        }
    }
}

/// Limits on render parameters: beyond them an image is a mistake, not a
/// request (16384² RGB f64 mean+variance accumulators are ~12 GiB).
pub const MAX_IMAGE_SIDE: u32 = 16_384;
/// At most 2^26 pixels (8192²): the film alone is 64 bytes a pixel on the
/// CPU (4 GiB here), so larger images fail up front instead of in the allocator.
pub const MAX_PIXELS: u64 = 1 << 26;
pub const MAX_SPP: u32 = 1 << 24;
pub const MAX_DEPTH: u32 = 1024;

impl RenderSettings {
    /// Checks the parameters; the error names the offending field.
    pub fn validate(&self) -> Result<(), SceneError> {
        let bad = |field: &str, msg: String| Err(SceneError::invalid(field, msg));
        if self.width == 0
            || self.height == 0
            || self.width > MAX_IMAGE_SIDE
            || self.height > MAX_IMAGE_SIDE
        {
            return bad(
                "render.width/height",
                format!(
                    "image size {}x{} must be between 1x1 and {MAX_IMAGE_SIDE}x{MAX_IMAGE_SIDE}",
                    self.width, self.height
                ),
            );
        }
        if self.width as u64 * self.height as u64 > MAX_PIXELS {
            return bad(
                "render.width/height",
                format!(
                    "image size {}x{} has more than {MAX_PIXELS} pixels",
                    self.width, self.height
                ),
            );
        }
        if self.spp == 0 || self.spp > MAX_SPP {
            return bad(
                "render.spp",
                format!(
                    "{} samples per pixel must be between 1 and {MAX_SPP}",
                    self.spp
                ),
            );
        }
        if self.max_depth == 0 || self.max_depth > MAX_DEPTH {
            return bad(
                "render.max_depth",
                format!(
                    "max depth {} must be between 1 and {MAX_DEPTH}",
                    self.max_depth
                ),
            );
        }
        Ok(())
    }
}

/// An affine placement: scale, then rotations, then translation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    pub matrix: Affine3A,
}

impl Default for Transform {
    fn default() -> Self {
        Self {
            matrix: Affine3A::IDENTITY,
        }
    }
}

impl Transform {
    /// `translate · rotation · scale`. `rotation` is applied to the scaled object.
    pub fn from_parts(scale: Vec3, rotation: Quat, translate: Vec3) -> Self {
        Self {
            matrix: Affine3A::from_scale_rotation_translation(scale, rotation, translate),
        }
    }

    /// Rotations about x, then y, then z (degrees), as the scene format states.
    pub fn rotation_xyz(x_deg: f32, y_deg: f32, z_deg: f32) -> Quat {
        Quat::from_rotation_z(z_deg.to_radians())
            * Quat::from_rotation_y(y_deg.to_radians())
            * Quat::from_rotation_x(x_deg.to_radians())
    }

    pub fn point(&self, p: Vec3) -> Vec3 {
        self.matrix.transform_point3(p)
    }

    pub fn vector(&self, v: Vec3) -> Vec3 {
        self.matrix.transform_vector3(v)
    }

    /// Normals transform by the inverse transpose.
    pub fn normal_matrix(&self) -> Mat3 {
        Mat3::from(self.matrix.matrix3).inverse().transpose()
    }

    /// The uniform scale factor, if the linear part is a similarity.
    pub fn uniform_scale(&self) -> Option<f32> {
        let m = Mat3::from(self.matrix.matrix3);
        let (a, b, c) = (m.x_axis.length(), m.y_axis.length(), m.z_axis.length());
        let tol = 1e-4 * a.max(b).max(c);
        let orthogonal = m.x_axis.dot(m.y_axis).abs() <= tol * a * b + 1e-12
            && m.y_axis.dot(m.z_axis).abs() <= tol * b * c + 1e-12
            && m.x_axis.dot(m.z_axis).abs() <= tol * a * c + 1e-12;
        ((a - b).abs() <= tol && (b - c).abs() <= tol && orthogonal).then_some(a)
    }

    pub fn is_finite(&self) -> bool {
        self.matrix.is_finite()
    }
}

/// An indexed triangle mesh before placement.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshInput {
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    /// Three indices per triangle.
    pub indices: Vec<u32>,
}

/// A validated scene with its BVH.
#[derive(Clone, Debug)]
pub struct Scene {
    pub camera_settings: CameraSettings,
    pub render: RenderSettings,
    pub background: Background,
    pub spheres: Vec<Sphere>,
    pub quads: Vec<Quad>,
    pub triangles: Vec<Triangle>,
    pub mesh: MeshData,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub images: Vec<ImageData>,
    /// All primitives in scene order; the index is the primitive id.
    pub primitives: Vec<Primitive>,
    /// Private: `leaf_prims` and `leaf_blocks` are derived from it
    /// ([`Scene::set_bvh`]).
    bvh: Bvh,
    /// What [`SceneBuilder::build`]'s BVH build reported.
    pub bvh_stats: BvhBuildStats,
    /// The traversal's copy of every primitive's geometry in BVH leaf
    /// order (`bvh.prim_order()`), made by [`Scene::set_bvh`]. The
    /// geometry above is read-only once built.
    leaf_prims: Vec<LeafPrim>,
    /// By BVH leaf ([`Bvh::leaves`]): one to four triangles by lane for
    /// the four-wide triangle test, or a mark that the leaf is tested
    /// entry by entry from `leaf_prims`. Made by [`Scene::set_bvh`].
    leaf_blocks: Vec<LeafBlock>,
}

impl Scene {
    /// The camera for an image of `width x height`.
    pub fn camera(&self, width: u32, height: u32) -> Camera {
        Camera::new(&self.camera_settings, width as f32 / height as f32)
    }

    /// The BVH over `primitives` (what the GPU uploads).
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// Replaces the BVH and re-copies the geometry into its leaf order: for
    /// tests that hand-edit a tree (a mutation must reach the traversal).
    /// Panics if `bvh` indexes a primitive this scene lacks.
    pub fn set_bvh(&mut self, bvh: Bvh) {
        assert!(
            bvh.prim_order()
                .iter()
                .all(|&p| (p as usize) < self.primitives.len()),
            "the BVH indexes a primitive the scene lacks"
        );
        self.leaf_prims = bvh
            .prim_order()
            .iter()
            .map(|&prim| LeafPrim::of(self, prim))
            .collect();
        self.leaf_blocks = bvh
            .leaves()
            .map(|entries| LeafBlock::of(&self.leaf_prims, entries))
            .collect();
        self.bvh = bvh;
    }

    pub fn bounds(&self) -> Aabb {
        self.bvh
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
        LeafPrim::of(self, prim).intersect(ray, &self.ray_constants(ray)?, t_min, t_max)
    }

    /// The per-ray constants of the primitive tests; `None` for an empty
    /// scene.
    #[inline]
    fn ray_constants(&self, ray: &Ray) -> Option<RayConstants> {
        let root = self.bvh.nodes().first()?;
        Some(RayConstants {
            shear: RayShear::new(ray.direction),
            inv_dir: ray.direction.recip(),
            pad: box_pad(Vec3::from(root.min), Vec3::from(root.max), ray),
        })
    }

    /// Closest hit in `(t_min, t_max)`, through the BVH. Leaves read the
    /// leaf-ordered copies in `leaf_prims`.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let c = self.ray_constants(ray)?;
        let leaves = LeafTests {
            prims: &self.leaf_prims,
            blocks: &self.leaf_blocks,
            ray,
            constants: c,
            t_min,
        };
        self.bvh.intersect(ray, t_max, leaves)
    }

    /// Closest hit by testing every primitive: the oracle for the BVH.
    /// Ties in t go to the smaller primitive id, as in the BVH traversal.
    /// Reads the scene's own arrays, not the traversal's copies.
    pub fn intersect_brute_force(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let c = self.ray_constants(ray)?;
        let mut best: Option<Hit> = None;
        for prim in 0..self.primitives.len() as u32 {
            if let Some(h) = LeafPrim::of(self, prim).intersect(ray, &c, t_min, t_max) {
                if best.is_none_or(|b| h.t < b.t) {
                    best = Some(h);
                }
            }
        }
        best
    }

    /// Everything shading needs about a hit.
    pub fn surface_interaction(&self, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        let p = self.primitives[hit.prim as usize];
        let (pos, ng, ns, uv, material, p_error) = match p.tag {
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
                (pos, n, n, uv, s.material, err)
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
                (pos, n, n, hit.uv, q.material, err)
            }
            _ => {
                let tri = &self.triangles[p.index as usize];
                let [i0, i1, i2] = tri.vertices.map(|i| i as usize);
                let m = &self.mesh;
                let (b1, b2) = (hit.uv.x, hit.uv.y);
                let b0 = 1.0 - b1 - b2;
                let pos = b0 * m.positions[i0] + b1 * m.positions[i1] + b2 * m.positions[i2];
                // pbrt-v4's bound for barycentric interpolation.
                let err = gamma(7)
                    * ((b0 * m.positions[i0]).abs()
                        + (b1 * m.positions[i1]).abs()
                        + (b2 * m.positions[i2]).abs())
                    .max_element();
                let ng = (m.positions[i1] - m.positions[i0])
                    .cross(m.positions[i2] - m.positions[i0])
                    .normalize_or(Vec3::Y);
                let mut ns = ng;
                if tri.flags & TRIANGLE_HAS_NORMALS != 0 {
                    let n = (b0 * m.normals[i0] + b1 * m.normals[i1] + b2 * m.normals[i2])
                        .normalize_or(ng);
                    ns = if n.dot(ng) < 0.0 { -n } else { n };
                }
                let uv = if tri.flags & TRIANGLE_HAS_UVS != 0 {
                    b0 * m.uvs[i0] + b1 * m.uvs[i1] + b2 * m.uvs[i2]
                } else {
                    hit.uv
                };
                (pos, ng, ns, uv, tri.material, err)
            }
        };
        SurfaceInteraction {
            p: pos,
            geometric_normal: ng,
            shading_normal: ns,
            uv,
            p_error,
            front_face: ray.direction.dot(ng) < 0.0,
            material,
        }
    }
}

/// A primitive's bounding box: the BVH build and [`Bvh::admits`] must see
/// the same bits, so both come here.
#[inline]
fn primitive_bounds(
    p: Primitive,
    spheres: &[Sphere],
    quads: &[Quad],
    triangles: &[Triangle],
    mesh: &MeshData,
) -> Aabb {
    match p.tag {
        primitive_tag::SPHERE => spheres[p.index as usize].bounds(),
        primitive_tag::QUAD => quads[p.index as usize].bounds(),
        _ => triangles[p.index as usize].bounds(mesh),
    }
}

/// One primitive with its geometry copied in: a BVH leaf entry reads one
/// contiguous 48-byte record instead of chasing primitive → shape → vertex
/// indices → positions (four dependent loads, most of them cache misses on
/// large meshes). The floats are the scene's own, so every test and box is
/// bit for bit what the scene's arrays give.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, PartialEq)]
struct LeafPrim {
    /// Sphere: center, (radius, 0, 0). Quad: corner, u, v. Triangle: its
    /// three vertices.
    p: [Vec3; 3],
    prim: u32,
    tag: u32,
}

impl LeafPrim {
    fn of(scene: &Scene, prim: u32) -> Self {
        let p = scene.primitives[prim as usize];
        let geometry = match p.tag {
            primitive_tag::SPHERE => {
                let s = &scene.spheres[p.index as usize];
                [s.center, Vec3::new(s.radius, 0.0, 0.0), Vec3::ZERO]
            }
            primitive_tag::QUAD => {
                let q = &scene.quads[p.index as usize];
                [q.corner, q.u, q.v]
            }
            _ => scene.triangles[p.index as usize]
                .vertices
                .map(|i| scene.mesh.positions[i as usize]),
        };
        LeafPrim {
            p: geometry,
            prim,
            tag: p.tag,
        }
    }

    /// [`primitive_bounds`], from the copied floats (the same operations).
    #[inline]
    fn bounds(&self) -> Aabb {
        let [a, b, c] = self.p;
        match self.tag {
            primitive_tag::SPHERE => Sphere {
                center: a,
                radius: b.x,
                material: 0,
            }
            .bounds(),
            primitive_tag::QUAD => Quad {
                corner: a,
                u: b,
                v: c,
                material: 0,
            }
            .bounds(),
            _ => Aabb::from_points(&[a, b, c]),
        }
    }

    /// The shape's test, then [`Bvh::admits`] with the ray's inverse
    /// direction and pad from `k`.
    #[inline]
    fn intersect(&self, ray: &Ray, k: &RayConstants, t_min: f32, t_max: f32) -> Option<Hit> {
        use crate::shapes::{intersect_quad, intersect_sphere, intersect_triangle_sheared};
        let [a, b, c] = self.p;
        let prim = self.prim;
        let hit = match self.tag {
            primitive_tag::SPHERE => intersect_sphere(a, b.x, ray, t_min, t_max).map(|t| Hit {
                t,
                prim,
                uv: Vec2::ZERO,
            }),
            primitive_tag::QUAD => {
                intersect_quad(a, b, c, ray, t_min, t_max).map(|(t, uv)| Hit { t, prim, uv })
            }
            _ => intersect_triangle_sheared(a, b, c, ray, k.shear.as_ref()?, t_min, t_max)
                .map(|(t, uv)| Hit { t, prim, uv }),
        }?;
        k.admits(self.bounds(), ray, hit.t).then_some(hit)
    }
}

/// One BVH leaf as the four-wide triangle test reads it: a leaf of one to
/// four triangles holds their vertices by lane in entry order and their
/// primitive ids (`u32::MAX` in an empty lane); any other leaf is marked
/// `by_entry` and tested entry by entry, `entries` of `leaf_prims` (kept
/// here so that the leaf needs no other load).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, PartialEq)]
struct LeafBlock {
    tris: Triangles4,
    prim: [u32; 4],
    entries: [u32; 2],
    by_entry: bool,
}

// A batched leaf fills the four lanes of `Triangles4`.
const _: () = assert!(LEAF_BATCH == 4);

/// Whether the leaf tests take primitives of this tag four at a time
/// ([`LeafBlock`]; what [`Bvh::build_batched`] is told): triangles.
fn batched(tag: u32) -> bool {
    tag == primitive_tag::TRIANGLE
}

impl LeafBlock {
    /// The block of the leaf of `entries` in `prims`.
    fn of(prims: &[LeafPrim], entries: std::ops::Range<usize>) -> Self {
        // The Bvh keeps its leaves' entries as u32: they fit.
        let [first, end] = [entries.start as u32, entries.end as u32];
        let prims = &prims[entries];
        let mut block = LeafBlock {
            tris: Triangles4::EMPTY,
            prim: [u32::MAX; 4],
            entries: [first, end],
            by_entry: true,
        };
        if (1..=LEAF_BATCH).contains(&prims.len()) && prims.iter().all(|p| batched(p.tag)) {
            block.by_entry = false;
            for (lane, p) in prims.iter().enumerate() {
                block.tris.set(lane, p.p);
                block.prim[lane] = p.prim;
            }
        }
        block
    }
}

/// One ray's tests of the leaf-ordered primitives, for [`Bvh::intersect`].
struct LeafTests<'a> {
    prims: &'a [LeafPrim],
    blocks: &'a [LeafBlock],
    ray: &'a Ray,
    constants: RayConstants,
    t_min: f32,
}

impl Leaves for LeafTests<'_> {
    #[inline]
    fn intersect(&mut self, entry: usize, t_max: f32) -> Option<Hit> {
        self.prims[entry].intersect(self.ray, &self.constants, self.t_min, t_max)
    }

    /// A leaf of triangles in one four-wide test, at the limit the first
    /// entry would be tested with; then, in entry order, each lane's hit
    /// is taken only if it lies below the limit as it stands by then
    /// (which only shrinks) and passes [`Bvh::admits`]: what testing the
    /// entries one by one gives, bit for bit.
    #[inline]
    fn intersect_leaf(&mut self, leaf: LeafRef, closest: &mut Closest) {
        let block = &self.blocks[leaf.index()];
        if block.by_entry {
            return intersect_entries(
                self,
                block.entries[0] as usize..block.entries[1] as usize,
                closest,
            );
        }
        // No shear: a zero direction, which hits no triangle.
        let Some(shear) = self.constants.shear.as_ref() else {
            return;
        };
        let hits = intersect_triangles4(&block.tris, self.ray, shear, self.t_min, closest.limit());
        let mut bits = hits.mask;
        while bits != 0 {
            let lane = bits.trailing_zeros() as usize & 3;
            bits &= bits - 1;
            let t = hits.t[lane];
            if t < closest.limit()
                && self
                    .constants
                    .admits(Aabb::from_points(&block.tris.get(lane)), self.ray, t)
            {
                closest.offer(Hit {
                    t,
                    prim: block.prim[lane],
                    uv: Vec2::new(hits.b1[lane], hits.b2[lane]),
                });
            }
        }
    }

    #[inline]
    fn prefetch(&self, leaf: LeafRef) {
        let block = &self.blocks[leaf.index()];
        if block.by_entry {
            crate::bvh::prefetch(&self.prims[block.entries[0] as usize..block.entries[1] as usize]);
        } else {
            crate::bvh::prefetch(block);
        }
    }
}

/// One ray's constants for the primitive tests of a traversal: the
/// triangle shear ([`RayShear`]; `None` for a zero direction) and what
/// [`Bvh::admits`] computes (inverse direction, box pad).
#[derive(Clone, Copy, Debug)]
struct RayConstants {
    shear: Option<RayShear>,
    inv_dir: Vec3,
    pad: f32,
}

impl RayConstants {
    /// [`Bvh::admits`] for a hit at `t` on a primitive with box `bounds`.
    #[inline]
    fn admits(&self, bounds: Aabb, ray: &Ray, t: f32) -> bool {
        intersect_aabb_padded(
            bounds.min,
            bounds.max,
            ray.origin,
            self.inv_dir,
            self.pad,
            t,
        )
        .is_some()
    }
}

/// Collects a scene, checks it, and builds its BVH.
#[derive(Clone, Debug, Default)]
pub struct SceneBuilder {
    pub camera: CameraSettings,
    pub render: RenderSettings,
    pub background: Option<Background>,
    spheres: Vec<Sphere>,
    quads: Vec<Quad>,
    triangles: Vec<Triangle>,
    mesh: MeshData,
    materials: Vec<Material>,
    textures: Vec<Texture>,
    images: Vec<ImageData>,
    primitives: Vec<Primitive>,
}

fn check_finite_vec(field: &str, v: Vec3) -> Result<(), SceneError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(SceneError::invalid(field, format!("{v} is not finite")))
    }
}

fn check_colour(field: &str, c: Vec3) -> Result<(), SceneError> {
    check_finite_vec(field, c)?;
    if c.min_element() < 0.0 {
        return Err(SceneError::invalid(
            field,
            format!("colour {c} has a negative component"),
        ));
    }
    Ok(())
}

impl SceneBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn add_image(&mut self, image: ImageData) -> u32 {
        self.images.push(image);
        self.images.len() as u32 - 1
    }

    /// Adds a texture after checking its references and values.
    pub fn add_texture(&mut self, texture: Texture) -> Result<u32, SceneError> {
        match texture {
            Texture::Constant(c) => check_colour("texture", c)?,
            Texture::Checker { scale, even, odd } => {
                if !scale.is_finite() {
                    return Err(SceneError::invalid(
                        "texture.scale",
                        format!("{scale} is not finite"),
                    ));
                }
                for (name, id) in [("even", even), ("odd", odd)] {
                    match self.textures.get(id as usize) {
                        None => {
                            return Err(SceneError::invalid(
                                &format!("texture.{name}"),
                                format!("texture index {id} does not exist"),
                            ))
                        }
                        Some(Texture::Checker { .. }) => {
                            return Err(SceneError::invalid(
                                &format!("texture.{name}"),
                                "a checker cannot nest another checker".into(),
                            ))
                        }
                        Some(_) => {}
                    }
                }
            }
            Texture::Image { image, factor } => {
                check_colour("texture.factor", factor)?;
                if image as usize >= self.images.len() {
                    return Err(SceneError::invalid(
                        "texture.image",
                        format!("image index {image} does not exist"),
                    ));
                }
            }
        }
        self.textures.push(texture);
        Ok(self.textures.len() as u32 - 1)
    }

    /// Shorthand for a constant texture.
    pub fn constant(&mut self, c: Vec3) -> Result<u32, SceneError> {
        self.add_texture(Texture::Constant(c))
    }

    /// Adds a material after checking its parameters.
    pub fn add_material(&mut self, material: Material) -> Result<u32, SceneError> {
        let tex_ok = |field: &str, id: u32| {
            if (id as usize) < self.textures.len() {
                Ok(())
            } else {
                Err(SceneError::invalid(
                    field,
                    format!("texture index {id} does not exist"),
                ))
            }
        };
        match material {
            Material::Lambertian { albedo } => tex_ok("albedo", albedo)?,
            Material::Metal { albedo, fuzz } => {
                tex_ok("albedo", albedo)?;
                if !(0.0..=1.0).contains(&fuzz) {
                    return Err(SceneError::invalid(
                        "fuzz",
                        format!("{fuzz} is outside [0, 1]"),
                    ));
                }
            }
            Material::Dielectric { ior, absorption } => {
                if !(ior.is_finite() && ior > 0.0) {
                    return Err(SceneError::invalid(
                        "ior",
                        format!("{ior} must be a positive finite number"),
                    ));
                }
                check_colour("absorption", absorption)?;
            }
            Material::DiffuseLight { emission } => tex_ok("emission", emission)?,
            Material::Ggx {
                base_color,
                metallic,
                roughness,
            } => {
                tex_ok("base_color", base_color)?;
                if !(0.0..=1.0).contains(&metallic) {
                    return Err(SceneError::invalid(
                        "metallic",
                        format!("{metallic} is outside [0, 1]"),
                    ));
                }
                if !(0.0..=1.0).contains(&roughness) {
                    return Err(SceneError::invalid(
                        "roughness",
                        format!("{roughness} is outside [0, 1]"),
                    ));
                }
            }
        }
        self.materials.push(material);
        Ok(self.materials.len() as u32 - 1)
    }

    fn check_material(&self, material: u32) -> Result<(), SceneError> {
        if (material as usize) < self.materials.len() {
            Ok(())
        } else {
            Err(SceneError::invalid(
                "material",
                format!("material index {material} does not exist"),
            ))
        }
    }

    fn push_primitive(&mut self, tag: u32, index: usize) {
        self.primitives.push(Primitive {
            tag,
            index: index as u32,
        });
    }

    /// A sphere, placed by `transform` (which must be a similarity: a
    /// sphere under non-uniform scale is an ellipsoid, not a sphere).
    pub fn add_sphere(
        &mut self,
        center: Vec3,
        radius: f32,
        material: u32,
        transform: &Transform,
    ) -> Result<(), SceneError> {
        self.check_material(material)?;
        check_finite_vec("center", center)?;
        if !(radius.is_finite() && radius != 0.0) {
            return Err(SceneError::invalid(
                "radius",
                format!("{radius} must be a finite non-zero number"),
            ));
        }
        let scale = transform.uniform_scale().ok_or_else(|| {
            SceneError::invalid("transform", "a sphere accepts only uniform scale".into())
        })?;
        let s = Sphere {
            center: transform.point(center),
            radius: radius * scale,
            material,
        };
        check_finite_vec("transform", s.center)?;
        if !(s.radius.is_finite() && s.radius != 0.0) {
            return Err(SceneError::invalid(
                "transform",
                format!("the placed radius {} is degenerate", s.radius),
            ));
        }
        self.spheres.push(s);
        self.push_primitive(primitive_tag::SPHERE, self.spheres.len() - 1);
        Ok(())
    }

    /// A parallelogram `corner + s·u + t·v`, placed by `transform`.
    pub fn add_quad(
        &mut self,
        corner: Vec3,
        u: Vec3,
        v: Vec3,
        material: u32,
        transform: &Transform,
    ) -> Result<(), SceneError> {
        self.check_material(material)?;
        for (f, x) in [("corner", corner), ("u", u), ("v", v)] {
            check_finite_vec(f, x)?;
        }
        let q = Quad {
            corner: transform.point(corner),
            u: transform.vector(u),
            v: transform.vector(v),
            material,
        };
        let n = q.u.cross(q.v);
        if !(n.is_finite() && n.length_squared() > 0.0 && q.corner.is_finite()) {
            return Err(SceneError::invalid(
                "u/v",
                "the quad is degenerate (u and v are parallel or zero)".into(),
            ));
        }
        self.quads.push(q);
        self.push_primitive(primitive_tag::QUAD, self.quads.len() - 1);
        Ok(())
    }

    /// An axis-aligned box in its own frame (six quads, outward normals).
    pub fn add_box(
        &mut self,
        min: Vec3,
        max: Vec3,
        material: u32,
        transform: &Transform,
    ) -> Result<(), SceneError> {
        check_finite_vec("min", min)?;
        check_finite_vec("max", max)?;
        if !min.cmplt(max).all() {
            return Err(SceneError::invalid(
                "min/max",
                format!("min {min} must be below max {max} on every axis"),
            ));
        }
        let d = max - min;
        let (dx, dy, dz) = (
            Vec3::new(d.x, 0.0, 0.0),
            Vec3::new(0.0, d.y, 0.0),
            Vec3::new(0.0, 0.0, d.z),
        );
        // Each face: corner, u, v with u × v pointing out of the box.
        let faces = [
            (Vec3::new(min.x, min.y, max.z), dx, dy),  // front (+z)
            (Vec3::new(max.x, min.y, max.z), -dz, dy), // right (+x)
            (Vec3::new(max.x, min.y, min.z), -dx, dy), // back (-z)
            (Vec3::new(min.x, min.y, min.z), dz, dy),  // left (-x)
            (Vec3::new(min.x, max.y, max.z), dx, -dz), // top (+y)
            (Vec3::new(min.x, min.y, min.z), dx, dz),  // bottom (-y)
        ];
        let mirror = Mat3::from(transform.matrix.matrix3).determinant() < 0.0;
        for (corner, u, v) in faces {
            // A mirroring transform flips u × v; swap to keep normals outward.
            let (u, v, c) = if mirror {
                (v, u, corner)
            } else {
                (u, v, corner)
            };
            self.add_quad(c, u, v, material, transform)?;
        }
        Ok(())
    }

    /// An indexed triangle mesh placed by `transform`. Degenerate
    /// triangles are kept (they never report a hit); out-of-range indices
    /// and non-finite data are errors.
    pub fn add_mesh(
        &mut self,
        mesh: &MeshInput,
        material: u32,
        transform: &Transform,
    ) -> Result<(), SceneError> {
        self.check_material(material)?;
        let n = mesh.positions.len();
        if mesh.indices.len() % 3 != 0 {
            return Err(SceneError::invalid(
                "indices",
                format!("{} indices is not a multiple of 3", mesh.indices.len()),
            ));
        }
        if let Some(bad) = mesh.indices.iter().find(|&&i| i as usize >= n) {
            return Err(SceneError::invalid(
                "indices",
                format!("index {bad} is out of range for {n} vertices"),
            ));
        }
        for (name, len) in [
            ("normals", mesh.normals.as_ref().map(Vec::len)),
            ("uvs", mesh.uvs.as_ref().map(Vec::len)),
        ] {
            if let Some(len) = len.filter(|&l| l != n) {
                return Err(SceneError::invalid(
                    name,
                    format!("{len} entries for {n} vertices"),
                ));
            }
        }
        if mesh.indices.is_empty() {
            return Err(SceneError::invalid(
                "indices",
                "the mesh has no triangles".into(),
            ));
        }
        let base = self.mesh.positions.len() as u32;
        if (base as usize + n) > u32::MAX as usize / 2 {
            return Err(SceneError::invalid("positions", "too many vertices".into()));
        }
        let nm = transform.normal_matrix();
        for (i, &p) in mesh.positions.iter().enumerate() {
            let wp = transform.point(p);
            if !wp.is_finite() {
                return Err(SceneError::invalid(
                    "positions",
                    format!("vertex {i} ({p}) is not finite once placed"),
                ));
            }
            self.mesh.positions.push(wp);
            let wn = mesh
                .normals
                .as_ref()
                .map_or(Vec3::ZERO, |ns| (nm * ns[i]).normalize_or_zero());
            self.mesh
                .normals
                .push(if wn.is_finite() { wn } else { Vec3::ZERO });
            let uv = mesh.uvs.as_ref().map_or(Vec2::ZERO, |uvs| uvs[i]);
            self.mesh
                .uvs
                .push(if uv.is_finite() { uv } else { Vec2::ZERO });
        }
        let flags = if mesh.normals.is_some() {
            TRIANGLE_HAS_NORMALS
        } else {
            0
        } | if mesh.uvs.is_some() {
            TRIANGLE_HAS_UVS
        } else {
            0
        };
        for tri in mesh.indices.chunks_exact(3) {
            self.triangles.push(Triangle {
                vertices: [base + tri[0], base + tri[1], base + tri[2]],
                material,
                flags,
            });
            self.push_primitive(primitive_tag::TRIANGLE, self.triangles.len() - 1);
        }
        Ok(())
    }

    pub fn material_count(&self) -> usize {
        self.materials.len()
    }

    pub fn texture_count(&self) -> usize {
        self.textures.len()
    }

    pub fn image(&self, id: u32) -> Option<&ImageData> {
        self.images.get(id as usize)
    }

    /// Checks the camera and settings and builds the BVH.
    pub fn build(self) -> Result<Scene, SceneError> {
        if self.primitives.is_empty() {
            return Err(SceneError::invalid(
                "objects",
                "the scene has no objects".into(),
            ));
        }
        self.render.validate()?;
        let c = &self.camera;
        for (f, v) in [
            ("camera.look_from", c.look_from),
            ("camera.look_at", c.look_at),
            ("camera.up", c.up),
        ] {
            check_finite_vec(f, v)?;
        }
        let view = c.look_at - c.look_from;
        if view.length_squared() == 0.0 {
            return Err(SceneError::invalid(
                "camera.look_at",
                "look_at equals look_from".into(),
            ));
        }
        if view
            .normalize()
            .cross(c.up.normalize_or_zero())
            .length_squared()
            < 1e-12
        {
            return Err(SceneError::invalid(
                "camera.up",
                "up is zero or parallel to the view direction".into(),
            ));
        }
        if !(c.vfov > 0.0 && c.vfov < 180.0) {
            return Err(SceneError::invalid(
                "camera.vfov",
                format!("{} must lie strictly between 0 and 180 degrees", c.vfov),
            ));
        }
        if !(c.aperture.is_finite() && c.aperture >= 0.0) {
            return Err(SceneError::invalid(
                "camera.aperture",
                format!("{} must be finite and non-negative", c.aperture),
            ));
        }
        if !(c.focus_distance.is_finite() && c.focus_distance > 0.0) {
            return Err(SceneError::invalid(
                "camera.focus_distance",
                format!("{} must be finite and positive", c.focus_distance),
            ));
        }
        let background = self.background.unwrap_or(Background::Solid(Vec3::ZERO));
        match background {
            Background::Solid(col) => check_colour("background.color", col)?,
            Background::Sky { horizon, zenith } => {
                check_colour("background.horizon", horizon)?;
                check_colour("background.zenith", zenith)?;
            }
            Background::Envmap {
                image,
                intensity,
                rotate_y,
            } => {
                if image as usize >= self.images.len() {
                    return Err(SceneError::invalid(
                        "background.path",
                        "envmap image missing".into(),
                    ));
                }
                if !(intensity.is_finite() && intensity >= 0.0 && rotate_y.is_finite()) {
                    return Err(SceneError::invalid(
                        "background.intensity",
                        format!("intensity {intensity} / rotate_y {rotate_y} must be finite, intensity non-negative"),
                    ));
                }
            }
        }
        let bounds: Vec<Aabb> = self
            .primitives
            .iter()
            .map(|&p| primitive_bounds(p, &self.spheres, &self.quads, &self.triangles, &self.mesh))
            .collect();
        let batched: Vec<bool> = self.primitives.iter().map(|p| batched(p.tag)).collect();
        let (bvh, bvh_stats) = Bvh::build_batched(&bounds, &batched);
        let mut scene = Scene {
            camera_settings: self.camera,
            render: self.render,
            background,
            spheres: self.spheres,
            quads: self.quads,
            triangles: self.triangles,
            mesh: self.mesh,
            materials: self.materials,
            textures: self.textures,
            images: self.images,
            primitives: self.primitives,
            bvh: Bvh::default(),
            bvh_stats,
            leaf_prims: Vec::new(),
            leaf_blocks: Vec::new(),
        };
        scene.set_bvh(bvh);
        Ok(scene)
    }
}
