//! The traversal's glue: every primitive's geometry copied into BVH leaf
//! order with their boxes, the four-wide triangle and quad blocks, and the
//! leaf tests
//! [`Bvh::intersect`] calls.

use super::primitive::{primitive_tag, Primitive};
use crate::bvh::{
    box_pad, intersect_aabb_padded, intersect_entries, Bvh, Closest, LeafRef, Leaves, LEAF_BATCH,
};
use crate::geometry::{Aabb, Hit, Ray};
use crate::mutants::{self, Mutant};
use crate::sdf::{SdfGrid, SdfVoxel};
use crate::shapes::{
    intersect_quads4, intersect_triangles4, Instance, MeshData, Quad, Quadric, Quads4, RayShear,
    Sphere, Triangle, Triangles4,
};
use glam::{Vec2, Vec3};

/// The scene's shapes placed by a map, which a leaf entry reads through
/// its index: quadrics, signed distance grids with their cells, and
/// instances.
#[derive(Clone, Copy)]
pub(super) struct Objects<'a> {
    pub(super) quadrics: &'a [Quadric],
    pub(super) grids: &'a [SdfGrid],
    pub(super) voxels: &'a [SdfVoxel],
    pub(super) instances: &'a [Instance],
}

impl Objects<'_> {
    /// The box of object primitive `p` (a quadric, a grid cell or an
    /// instance).
    fn bounds(&self, p: Primitive) -> Aabb {
        match p.tag {
            primitive_tag::QUADRIC => self.quadrics[p.index as usize].bounds,
            primitive_tag::INSTANCE => self.instances[p.index as usize].map.bounds,
            _ => {
                let v = self.voxels[p.index as usize];
                let g = &self.grids[v.grid as usize];
                g.cell_bounds(v.cell, g.map_f64)
            }
        }
    }

    /// Object primitive `tag` `index`'s hit on `ray`.
    #[inline]
    fn intersect(&self, tag: u32, index: u32, ray: &Ray, t_min: f32, t_max: f32) -> Option<f32> {
        match tag {
            primitive_tag::QUADRIC => self.quadrics[index as usize].intersect(ray, t_min, t_max),
            _ => {
                let v = self.voxels[index as usize];
                let g = &self.grids[v.grid as usize];
                g.intersect_cell(v.cell, &g.map.object_ray(ray), t_min, t_max)
            }
        }
    }
}

/// A primitive's bounding box: the BVH build and [`Bvh::admits`] must see
/// the same bits, so both come here.
#[inline]
pub(super) fn primitive_bounds(
    p: Primitive,
    spheres: &[Sphere],
    quads: &[Quad],
    objects: Objects,
    triangles: &[Triangle],
    mesh: &MeshData,
) -> Aabb {
    match p.tag {
        primitive_tag::SPHERE => spheres[p.index as usize].bounds(),
        primitive_tag::QUAD => quads[p.index as usize].bounds(),
        primitive_tag::QUADRIC | primitive_tag::SDF_VOXEL | primitive_tag::INSTANCE => {
            objects.bounds(p)
        }
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
pub(super) struct LeafPrim {
    /// Sphere: center, (radius, 0, 0). Quad: corner, u, v. Triangle: its
    /// three vertices. Quadric, grid cell, instance: its box's corners
    /// and (its index's bits, 0, 0): its test reads the scene's record.
    p: [Vec3; 3],
    prim: u32,
    /// The primitive's tag in the low 16 bits; [`LeafPrim::ALPHA`] set
    /// for a triangle whose material has an alpha (its hits go through
    /// the scene's `alpha_covers`; a bit here so that other entries never
    /// read the triangle record).
    tag: u32,
}

impl LeafPrim {
    /// The bit of `tag` that marks a triangle with an alpha.
    const ALPHA: u32 = 1 << 16;

    /// Primitive `prim` of kind `tag` at its points `p` (a sphere: its
    /// center and (radius, 0, 0); a quad: corner, u, v; a triangle: its
    /// vertices), a triangle whose material has an alpha where `alpha`.
    pub(super) fn new(prim: u32, tag: u32, p: [Vec3; 3], alpha: bool) -> Self {
        LeafPrim {
            p,
            prim,
            tag: tag | if alpha { Self::ALPHA } else { 0 },
        }
    }

    /// The primitive's kind (`primitive_tag`).
    #[inline]
    fn kind(&self) -> u32 {
        self.tag & (Self::ALPHA - 1)
    }

    /// Whether a hit on it must pass the scene's `alpha_covers`.
    #[inline]
    pub(super) fn has_alpha(&self) -> bool {
        self.tag & Self::ALPHA != 0
    }

    /// [`primitive_bounds`], from the copied floats (the same operations).
    #[inline]
    pub(super) fn bounds(&self) -> Aabb {
        let [a, b, c] = self.p;
        match self.kind() {
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
            primitive_tag::QUADRIC | primitive_tag::SDF_VOXEL | primitive_tag::INSTANCE => {
                Aabb { min: a, max: b }
            }
            _ => Aabb::from_points(&[a, b, c]),
        }
    }

    /// The shape's test, then [`Bvh::admits`] with the ray's inverse
    /// direction and pad from `k`, against the box [`LeafPrim::bounds`]
    /// computes. An instance's test is `covers`' walk of its group.
    #[inline]
    pub(super) fn intersect<C: Coverage>(
        &self,
        ray: &Ray,
        k: &RayConstants,
        objects: Objects,
        covers: &C,
        t_min: f32,
        t_max: f32,
    ) -> Option<Hit> {
        self.intersect_in(self.bounds(), ray, k, objects, covers, t_min, t_max)
    }

    /// [`LeafPrim::intersect`] with the box given (`bounds`: what
    /// [`LeafPrim::bounds`] computes, kept by the caller).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn intersect_in<C: Coverage>(
        &self,
        bounds: Aabb,
        ray: &Ray,
        k: &RayConstants,
        objects: Objects,
        covers: &C,
        t_min: f32,
        t_max: f32,
    ) -> Option<Hit> {
        let hit = self.intersect_shape(ray, k, objects, covers, t_min, t_max)?;
        k.admits(bounds, ray, hit.t).then_some(hit)
    }

    /// The shape's test alone (no [`Bvh::admits`]).
    #[inline]
    fn intersect_shape<C: Coverage>(
        &self,
        ray: &Ray,
        k: &RayConstants,
        objects: Objects,
        covers: &C,
        t_min: f32,
        t_max: f32,
    ) -> Option<Hit> {
        use crate::shapes::{intersect_quad, intersect_sphere, intersect_triangle_sheared};
        let [a, b, c] = self.p;
        let prim = self.prim;
        match self.kind() {
            primitive_tag::SPHERE => {
                intersect_sphere(a, b.x, ray, t_min, t_max).map(|t| Hit::new(t, prim, Vec2::ZERO))
            }
            primitive_tag::QUAD => {
                intersect_quad(a, b, c, ray, t_min, t_max).map(|(t, uv)| Hit::new(t, prim, uv))
            }
            tag @ (primitive_tag::QUADRIC | primitive_tag::SDF_VOXEL) => objects
                .intersect(tag, c.x.to_bits(), ray, t_min, t_max)
                .map(|t| Hit::new(t, prim, Vec2::ZERO)),
            primitive_tag::INSTANCE => {
                let inner = covers.instance_hit(c.x.to_bits(), ray, t_min, t_max)?;
                Some(Hit {
                    t: inner.t,
                    prim,
                    uv: inner.uv,
                    sub: inner.prim,
                })
            }
            _ => intersect_triangle_sheared(a, b, c, ray, k.shear.as_ref()?, t_min, t_max)
                .map(|(t, uv)| Hit::new(t, prim, uv)),
        }
    }
}

/// One BVH leaf as the four-wide tests read it: a leaf of one to four
/// triangles holds their vertices by lane in entry order, a leaf of one
/// to four quads the index of its [`Quads4`] in the scene's quad blocks,
/// and either its primitive ids (`u32::MAX` in an empty lane); any other
/// leaf is tested entry by entry, `entries` of `leaf_prims` (kept here so
/// that the leaf needs no other load).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct LeafBlock {
    tris: Triangles4,
    prim: [u32; 4],
    entries: [u32; 2],
    quads: u32,
    kind: LeafKind,
    /// Bit `lane` set: that lane's triangle has an alpha
    /// ([`LeafPrim::has_alpha`]).
    alpha: u8,
}

/// How a leaf is tested.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum LeafKind {
    ByEntry,
    Triangles,
    Quads,
}

// A batched leaf fills the four lanes of `Triangles4` or `Quads4`.
const _: () = assert!(LEAF_BATCH == 4);

/// Whether the leaf tests take primitives of this tag four at a time
/// ([`LeafBlock`]; what [`Bvh::build_batched`] is told): triangles. (A
/// leaf of quads is tested four-wide too, but quads are few: the build is
/// not asked to gather them.)
pub(super) fn batched(tag: u32) -> bool {
    tag == primitive_tag::TRIANGLE
}

impl LeafBlock {
    /// The block of the leaf of `entries` in `prims`; a leaf of quads
    /// appends its lanes to `quad_blocks`.
    pub(super) fn of(
        prims: &[LeafPrim],
        entries: std::ops::Range<usize>,
        quad_blocks: &mut Vec<Quads4>,
    ) -> Self {
        // The Bvh keeps its leaves' entries as u32: they fit.
        let [first, end] = [entries.start as u32, entries.end as u32];
        let prims = &prims[entries];
        let mut block = LeafBlock {
            tris: Triangles4::EMPTY,
            prim: [u32::MAX; 4],
            entries: [first, end],
            quads: 0,
            kind: LeafKind::ByEntry,
            alpha: 0,
        };
        if !(1..=LEAF_BATCH).contains(&prims.len()) {
            return block;
        }
        if prims.iter().all(|p| batched(p.kind())) {
            block.kind = LeafKind::Triangles;
            for (lane, p) in prims.iter().enumerate() {
                block.tris.set(lane, p.p);
                block.prim[lane] = p.prim;
                block.alpha |= u8::from(p.has_alpha()) << lane;
            }
        } else if prims.iter().all(|p| p.kind() == primitive_tag::QUAD) {
            block.kind = LeafKind::Quads;
            // Fewer leaves than primitives: the index fits.
            block.quads = quad_blocks.len() as u32;
            let mut quads = Quads4::EMPTY;
            for (lane, p) in prims.iter().enumerate() {
                let [corner, u, v] = p.p;
                quads.set(lane, corner, u, v);
                block.prim[lane] = p.prim;
            }
            quad_blocks.push(quads);
        }
        block
    }
}

/// One ray's tests of the leaf-ordered primitives, for [`Bvh::intersect`].
pub(super) struct LeafTests<'a, C: Coverage> {
    pub(super) prims: &'a [LeafPrim],
    /// `prims`' boxes ([`LeafPrim::bounds`], computed once: a quad's
    /// directed roundings cost more than its hit test).
    pub(super) bounds: &'a [Aabb],
    pub(super) blocks: &'a [LeafBlock],
    pub(super) quad_blocks: &'a [Quads4],
    pub(super) objects: Objects<'a>,
    pub(super) ray: &'a Ray,
    pub(super) constants: RayConstants,
    pub(super) t_min: f32,
    /// Whether a hit on a triangle with an alpha stands (the scene's
    /// `alpha_covers`).
    pub(super) covers: &'a C,
}

/// What a leaf test asks of the scene: whether a hit on a triangle with
/// an alpha stands (the scene's coverage, `Scene::alpha_covers`), and an
/// instance's hit (the walk of its group).
pub(super) trait Coverage {
    fn covers(&self, ray: &Ray, hit: &Hit) -> bool;
    /// The closest hit in `(t_min, t_max)` of `ray` (in the scene's
    /// space) with instance `index`'s group: `prim` the group's triangle
    /// (an index into the scene's triangles), `t` on `ray`.
    fn instance_hit(&self, index: u32, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit>;
}

impl<C: Coverage> Leaves for LeafTests<'_, C> {
    #[inline]
    fn intersect(&mut self, entry: usize, t_max: f32) -> Option<Hit> {
        let prim = &self.prims[entry];
        let hit = prim.intersect_in(
            self.bounds[entry],
            self.ray,
            &self.constants,
            self.objects,
            self.covers,
            self.t_min,
            t_max,
        )?;
        (!prim.has_alpha() || self.covers.covers(self.ray, &hit)).then_some(hit)
    }

    /// A leaf of triangles or of quads in one four-wide test, at the
    /// limit the first entry would be tested with; then, in entry order,
    /// each lane's hit is taken only if it lies below the limit as it
    /// stands by then (which only shrinks), passes [`Bvh::admits`] and,
    /// for a triangle with an alpha, the scene's `alpha_covers`: what testing
    /// the entries one by one gives, bit for bit.
    #[inline]
    fn intersect_leaf(&mut self, leaf: LeafRef, closest: &mut Closest) {
        let block = &self.blocks[leaf.index()];
        let first = block.entries[0] as usize;
        let hits = match block.kind {
            LeafKind::ByEntry => {
                return intersect_entries(self, first..block.entries[1] as usize, closest);
            }
            LeafKind::Triangles => {
                // No shear: a zero direction, which hits no triangle.
                let Some(shear) = self.constants.shear.as_ref() else {
                    return;
                };
                intersect_triangles4(&block.tris, self.ray, shear, self.t_min, closest.limit())
            }
            LeafKind::Quads => intersect_quads4(
                &self.quad_blocks[block.quads as usize],
                self.ray,
                self.t_min,
                closest.limit(),
            ),
        };
        let mut bits = hits.mask;
        while bits != 0 {
            let lane = bits.trailing_zeros() as usize & 3;
            bits &= bits - 1;
            let t = hits.t[lane];
            // A triangle's box from its lanes (in cache already; a mesh's
            // `bounds` entry may not be), a quad's from `bounds`.
            let bounds = match block.kind {
                LeafKind::Triangles => Aabb::from_points(&block.tris.get(lane)),
                _ => self.bounds[first + lane],
            };
            if t < closest.limit() && self.constants.admits(bounds, self.ray, t) {
                let hit = Hit::new(t, block.prim[lane], Vec2::new(hits.b1[lane], hits.b2[lane]));
                if block.alpha & (1 << lane) == 0
                    || mutants::is(Mutant::AlphaIgnoredInLeafBlocks)
                    || self.covers.covers(self.ray, &hit)
                {
                    closest.offer(hit);
                }
            }
        }
    }

    #[inline(always)]
    fn prefetch(&self, leaf: LeafRef) {
        let block = &self.blocks[leaf.index()];
        match block.kind {
            LeafKind::ByEntry => crate::bvh::prefetch(
                &self.prims[block.entries[0] as usize..block.entries[1] as usize],
            ),
            LeafKind::Triangles => crate::bvh::prefetch(block),
            LeafKind::Quads => {
                crate::bvh::prefetch(block);
                crate::bvh::prefetch(&self.quad_blocks[block.quads as usize]);
            }
        }
    }
}

/// One ray's constants for the primitive tests of a traversal: the
/// triangle shear ([`RayShear`]; `None` for a zero direction) and what
/// [`Bvh::admits`] computes (inverse direction, box pad).
#[derive(Clone, Copy, Debug)]
pub(super) struct RayConstants {
    pub(super) shear: Option<RayShear>,
    pub(super) inv_dir: Vec3,
    pub(super) pad: f32,
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

/// A BVH with the traversal's copies of what it holds: the scene's, over
/// its primitive list, or an instanced group's, over its triangles.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct Accel {
    pub(super) bvh: Bvh,
    /// Every entry's geometry in leaf order (`bvh.prim_order()`).
    pub(super) prims: Vec<LeafPrim>,
    /// The box of each of `prims` ([`LeafPrim::bounds`], the bits the BVH
    /// build saw), for [`Bvh::admits`].
    pub(super) bounds: Vec<Aabb>,
    /// By BVH leaf ([`Bvh::leaves`]): one to four triangles by lane for
    /// the four-wide triangle test, the index of one to four quads' lanes
    /// in `quad_blocks`, or a mark that the leaf is tested entry by entry
    /// from `prims`.
    pub(super) blocks: Vec<LeafBlock>,
    /// The lanes of the leaves of quads, by [`LeafBlock`]'s index.
    pub(super) quad_blocks: Vec<Quads4>,
}

impl Accel {
    /// `bvh` with entry `i`'s geometry `leaf(bvh.prim_order()[i])`.
    pub(super) fn new(bvh: Bvh, leaf: impl Fn(u32) -> LeafPrim) -> Self {
        let prims: Vec<LeafPrim> = bvh.prim_order().iter().map(|&p| leaf(p)).collect();
        let bounds = prims.iter().map(LeafPrim::bounds).collect();
        let mut quad_blocks = Vec::new();
        let blocks = bvh
            .leaves()
            .map(|entries| LeafBlock::of(&prims, entries, &mut quad_blocks))
            .collect();
        Accel {
            bvh,
            prims,
            bounds,
            blocks,
            quad_blocks,
        }
    }

    /// The per-ray constants of the primitive tests (the pad from this
    /// tree's root); `None` for an empty tree.
    #[inline]
    pub(super) fn constants(&self, ray: &Ray) -> Option<RayConstants> {
        let root = self.bvh.nodes().first()?;
        Some(RayConstants {
            shear: RayShear::new(ray.direction),
            inv_dir: ray.direction.recip(),
            pad: box_pad(Vec3::from(root.min), Vec3::from(root.max), ray),
        })
    }

    /// Closest hit in `(t_min, t_max)` through the tree.
    #[inline]
    pub(super) fn intersect<C: Coverage>(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        objects: Objects,
        covers: &C,
    ) -> Option<Hit> {
        let leaves = LeafTests {
            prims: &self.prims,
            bounds: &self.bounds,
            blocks: &self.blocks,
            quad_blocks: &self.quad_blocks,
            objects,
            ray,
            constants: self.constants(ray)?,
            t_min,
            covers,
        };
        self.bvh.intersect(ray, t_max, leaves)
    }
}

/// A group of triangles kept once, in its own object space, and drawn by
/// its instances (Mitsuba's `shapegroup`): the second level of the
/// scene's two-level tree.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Group {
    /// Its triangles: this range of the scene's triangles.
    pub(super) triangles: std::ops::Range<u32>,
    pub(super) accel: Accel,
}

impl Group {
    /// Its triangles' indices in the scene's triangles.
    pub fn triangles(&self) -> std::ops::Range<u32> {
        self.triangles.clone()
    }

    /// Its BVH, over its triangles in order (entry `i` of the tree is
    /// triangle `triangles().start + i`).
    pub fn bvh(&self) -> &Bvh {
        &self.accel.bvh
    }
}
