//! The traversal's glue: every primitive's geometry copied into BVH leaf
//! order, the four-wide triangle blocks, and the leaf tests
//! [`Bvh::intersect`] calls.

use super::{primitive_tag, Primitive, Scene};
#[cfg(doc)]
use crate::bvh::Bvh;
use crate::bvh::{intersect_aabb_padded, intersect_entries, Closest, LeafRef, Leaves, LEAF_BATCH};
use crate::geometry::{Aabb, Hit, Ray};
use crate::shapes::{intersect_triangles4, MeshData, Quad, RayShear, Sphere, Triangle, Triangles4};
use glam::{Vec2, Vec3};

/// A primitive's bounding box: the BVH build and [`Bvh::admits`] must see
/// the same bits, so both come here.
#[inline]
pub(super) fn primitive_bounds(
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
pub(super) struct LeafPrim {
    /// Sphere: center, (radius, 0, 0). Quad: corner, u, v. Triangle: its
    /// three vertices.
    p: [Vec3; 3],
    prim: u32,
    tag: u32,
}

impl LeafPrim {
    pub(super) fn of(scene: &Scene, prim: u32) -> Self {
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
    pub(super) fn intersect(
        &self,
        ray: &Ray,
        k: &RayConstants,
        t_min: f32,
        t_max: f32,
    ) -> Option<Hit> {
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
pub(super) struct LeafBlock {
    tris: Triangles4,
    prim: [u32; 4],
    entries: [u32; 2],
    by_entry: bool,
}

// A batched leaf fills the four lanes of `Triangles4`.
const _: () = assert!(LEAF_BATCH == 4);

/// Whether the leaf tests take primitives of this tag four at a time
/// ([`LeafBlock`]; what [`Bvh::build_batched`] is told): triangles.
pub(super) fn batched(tag: u32) -> bool {
    tag == primitive_tag::TRIANGLE
}

impl LeafBlock {
    /// The block of the leaf of `entries` in `prims`.
    pub(super) fn of(prims: &[LeafPrim], entries: std::ops::Range<usize>) -> Self {
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
pub(super) struct LeafTests<'a> {
    pub(super) prims: &'a [LeafPrim],
    pub(super) blocks: &'a [LeafBlock],
    pub(super) ray: &'a Ray,
    pub(super) constants: RayConstants,
    pub(super) t_min: f32,
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
