//! The Intel Embree 4 oracle (cargo feature `embree`): the same
//! [`Scene`](crate::scene::Scene), intersected by an independent library,
//! so that the reference's BVH and intersection routines are checked
//! against code they share nothing with.
//!
//! The Embree scene is built from the reference scene's world-space arrays:
//! - triangles: one `RTC_GEOMETRY_TYPE_TRIANGLE` mesh over the scene's
//!   shared vertex array (Embree's `(u, v)` are the barycentrics of
//!   vertices 1 and 2, as in the reference);
//! - quads: one `RTC_GEOMETRY_TYPE_QUAD` mesh, each parallelogram as the
//!   four vertices `corner, corner + u, corner + u + v, corner + v`;
//! - spheres: one `RTC_GEOMETRY_TYPE_SPHERE_POINT` geometry (x, y, z, |r|).
//!   Sphere points, not user geometry, because a user geometry would run
//!   the reference's own `intersect_sphere` inside Embree and so check
//!   only Embree's BVH, never the sphere arithmetic. Embree's sphere points
//!   report the far root when the near one lies before `tnear`, so rays
//!   from inside a sphere hit it, as in the reference. A negative radius
//!   (an inward-facing sphere) is the same surface: Embree gets `|r|`.
//!
//! The scene uses `RTC_SCENE_FLAG_ROBUST` (Embree's watertight-leaning
//! mode: no optimizations that trade accuracy for speed) and
//! `RTC_BUILD_QUALITY_HIGH`.
//!
//! Interval semantics: the reference accepts hits with `t_min < t < t_max`;
//! Embree accepts `tnear <= t <= tfar`. [`EmbreeScene::intersect`] passes
//! the next float above `t_min` and below `t_max`, so both answer the
//! same question.
//!
//! Coverage (glTF alpha, [`crate::material::Alpha`]): where the scene's
//! triangles have one, the triangle geometry gets an intersection filter
//! (Embree's any-hit callback, `rtcSetGeometryIntersectFilterFunction`)
//! that rejects a hit the surface does not cover there, as the reference's
//! traversal does. The decision is the reference's
//! [`Scene::alpha_covers`] (the alpha texture, the cutoff, BLEND's hash),
//! asked at Embree's own hit (its `t` and barycentrics): what Embree
//! checks is that its BVH visits the cut-out surfaces' other hits, and that
//! a hit rejected there does not end the search.
//!
//! Besides one prefetch hint ([`crate::bvh::prefetch`]), this is the only
//! module of the crate with `unsafe` code: FFI calls into libembree4
//! through `embree4-sys`. Every call's error state is checked.

use crate::geometry::{next_down, next_up, Ray};
use crate::scene::{primitive_tag, Scene};
use crate::shapes::TRIANGLE_HAS_ALPHA;
use embree4_sys as sys;
use glam::{Vec2, Vec3};
use std::ffi::c_void;
use std::ptr;

/// A failure reported by Embree, with the step that failed.
#[derive(Debug, thiserror::Error)]
#[error("embree: {step}: {code:?}")]
pub struct EmbreeError {
    pub step: &'static str,
    pub code: Option<sys::RTCError>,
}

/// Embree's closest hit, translated back to the reference's primitive ids.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmbreeHit {
    pub t: f32,
    /// Index into `Scene::primitives`.
    pub prim: u32,
    /// Embree's `(u, v)`: barycentrics of vertices 1 and 2 for triangles;
    /// for quads, the coordinates in the triangle of the split that was hit.
    pub uv: Vec2,
    /// Embree's unnormalized geometric normal.
    pub ng: Vec3,
}

/// A committed Embree scene mirroring one reference scene.
pub struct EmbreeScene {
    device: sys::RTCDevice,
    scene: sys::RTCScene,
    /// For each Embree geometry id, the reference primitive id of each of
    /// its Embree primitives.
    prim_ids: Vec<Vec<u32>>,
    /// What the triangle geometry's intersection filter reads, where the
    /// scene has triangles with a coverage: boxed so that the address
    /// Embree holds stays put; dropped after the Embree scene (the drop
    /// releases the scene first).
    filter: Option<Box<AlphaFilter>>,
}

/// The intersection filter's data: the reference scene (for
/// [`Scene::alpha_covers`]) and the reference id of each Embree triangle.
struct AlphaFilter {
    scene: Scene,
    prims: Vec<u32>,
}

/// Embree's intersection filter of the triangle geometry: rejects a hit
/// the surface does not cover ([`Scene::alpha_covers`] at Embree's hit).
unsafe extern "C" fn alpha_filter(args: *const sys::RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes a valid argument block; `geometryUserPtr` is
    // the `AlphaFilter` set with the filter, alive while the scene is
    // (EmbreeScene owns both); rtcIntersect1 calls with N = 1, whose ray
    // and hit blocks are laid out as RTCRay and RTCHit.
    unsafe {
        let args = &*args;
        if args.N != 1 || *args.valid == 0 {
            return;
        }
        let data = &*(args.geometryUserPtr as *const AlphaFilter);
        let ray = &*(args.ray as *const sys::RTCRay);
        let hit = &*(args.hit as *const sys::RTCHit);
        let Some(&prim) = data.prims.get(hit.primID as usize) else {
            return;
        };
        let r = Ray {
            origin: Vec3::new(ray.org_x, ray.org_y, ray.org_z),
            direction: Vec3::new(ray.dir_x, ray.dir_y, ray.dir_z),
        };
        let h = crate::geometry::Hit::new(ray.tfar, prim, Vec2::new(hit.u, hit.v));
        if !data.scene.alpha_covers(&r, &h) {
            *args.valid = 0;
        }
    }
}

// SAFETY: Embree documents committed scenes as safe to traverse from any
// number of threads at once (rtcIntersect1 only reads the scene), and the
// handles are never mutated after `EmbreeScene::new` returns; dropping
// releases them once.
unsafe impl Send for EmbreeScene {}
unsafe impl Sync for EmbreeScene {}

fn check(device: sys::RTCDevice, step: &'static str) -> Result<(), EmbreeError> {
    // SAFETY: `device` is a live device handle (or null, which Embree
    // accepts here and answers with the error of the last device creation).
    let code = unsafe { sys::rtcGetDeviceError(device) };
    if code == sys::RTCError::NONE {
        Ok(())
    } else {
        Err(EmbreeError {
            step,
            code: Some(code),
        })
    }
}

/// One geometry being filled: released on every path (Embree's scene
/// keeps its own reference once attached).
struct GeometryGuard(sys::RTCGeometry);

impl Drop for GeometryGuard {
    fn drop(&mut self) {
        // SAFETY: the handle came from rtcNewGeometry and is released once.
        unsafe { sys::rtcReleaseGeometry(self.0) }
    }
}

impl EmbreeScene {
    /// Builds and commits the Embree twin of `scene`.
    pub fn new(scene: &Scene) -> Result<Self, EmbreeError> {
        // SAFETY: a null config string selects Embree's defaults.
        let device = unsafe { sys::rtcNewDevice(ptr::null()) };
        if device.is_null() {
            return Err(EmbreeError {
                step: "rtcNewDevice",
                code: None,
            });
        }
        // From here on `me` owns the device (and the scene) and releases them on error.
        let mut me = EmbreeScene {
            device,
            scene: ptr::null_mut(),
            prim_ids: Vec::new(),
            filter: None,
        };
        // SAFETY: `device` is live.
        me.scene = unsafe { sys::rtcNewScene(device) };
        check(device, "rtcNewScene")?;
        if me.scene.is_null() {
            return Err(EmbreeError {
                step: "rtcNewScene",
                code: None,
            });
        }
        // SAFETY: `me.scene` is live and not yet committed.
        unsafe {
            sys::rtcSetSceneFlags(me.scene, sys::RTCSceneFlags::ROBUST);
            sys::rtcSetSceneBuildQuality(me.scene, sys::RTCBuildQuality::HIGH);
        }
        check(device, "scene flags")?;

        let (mut tris, mut quads, mut spheres) = (Vec::new(), Vec::new(), Vec::new());
        for (id, p) in scene.primitives().iter().enumerate() {
            match p.tag {
                primitive_tag::SPHERE => spheres.push((id as u32, p.index)),
                primitive_tag::QUAD => quads.push((id as u32, p.index)),
                primitive_tag::TRIANGLE => tris.push((id as u32, p.index)),
                // Disks, cylinders and textured spheres would be Embree
                // user geometry, and instances Embree instances, which
                // this oracle does not build.
                _ => return Err(EmbreeError {
                    step: "a quadric, signed distance grid or instance has no Embree geometry here",
                    code: None,
                }),
            }
        }
        if !tris.is_empty() {
            let vertices: Vec<[f32; 3]> = scene
                .mesh()
                .positions
                .iter()
                .map(|p| p.to_array())
                .collect();
            let indices: Vec<[u32; 3]> = tris
                .iter()
                .map(|&(_, i)| scene.triangles()[i as usize].vertices)
                .collect();
            let alpha = tris
                .iter()
                .any(|&(_, i)| scene.triangles()[i as usize].flags & TRIANGLE_HAS_ALPHA != 0);
            if alpha {
                me.filter = Some(Box::new(AlphaFilter {
                    scene: scene.clone(),
                    prims: tris.iter().map(|&(id, _)| id).collect(),
                }));
            }
            let filter = me
                .filter
                .as_ref()
                .map(|f| &**f as *const AlphaFilter as *mut c_void);
            me.attach(
                sys::RTCGeometryType::TRIANGLE,
                (sys::RTCFormat::FLOAT3, &vertices),
                (sys::RTCFormat::UINT3, &indices),
                filter,
            )?;
            me.prim_ids.push(tris.iter().map(|&(id, _)| id).collect());
        }
        if !quads.is_empty() {
            let mut vertices: Vec<[f32; 3]> = Vec::with_capacity(4 * quads.len());
            for &(_, i) in &quads {
                let q = &scene.quads()[i as usize];
                for v in [
                    q.corner,
                    q.corner + q.u,
                    q.corner + q.u + q.v,
                    q.corner + q.v,
                ] {
                    vertices.push(v.to_array());
                }
            }
            let indices: Vec<[u32; 4]> = (0..quads.len() as u32)
                .map(|k| [4 * k, 4 * k + 1, 4 * k + 2, 4 * k + 3])
                .collect();
            me.attach(
                sys::RTCGeometryType::QUAD,
                (sys::RTCFormat::FLOAT3, &vertices),
                (sys::RTCFormat::UINT4, &indices),
                None,
            )?;
            me.prim_ids.push(quads.iter().map(|&(id, _)| id).collect());
        }
        if !spheres.is_empty() {
            let points: Vec<[f32; 4]> = spheres
                .iter()
                .map(|&(_, i)| {
                    let s = &scene.spheres()[i as usize];
                    [s.center.x, s.center.y, s.center.z, s.radius.abs()]
                })
                .collect();
            me.attach::<[f32; 4], [u32; 0]>(
                sys::RTCGeometryType::SPHERE_POINT,
                (sys::RTCFormat::FLOAT4, &points),
                (sys::RTCFormat::UNDEFINED, &[]),
                None,
            )?;
            me.prim_ids
                .push(spheres.iter().map(|&(id, _)| id).collect());
        }
        // SAFETY: every geometry is committed and attached.
        unsafe { sys::rtcCommitScene(me.scene) };
        check(device, "rtcCommitScene")?;
        Ok(me)
    }

    /// Creates, fills, commits and attaches one geometry, with
    /// [`alpha_filter`] over `filter` (its data) where given. Geometry ids
    /// are handed out in attach order from 0, which `prim_ids` relies on.
    fn attach<V: Copy, I: Copy>(
        &self,
        kind: sys::RTCGeometryType,
        (vertex_format, vertices): (sys::RTCFormat, &[V]),
        (index_format, indices): (sys::RTCFormat, &[I]),
        filter: Option<*mut c_void>,
    ) -> Result<(), EmbreeError> {
        // SAFETY: the device is live; each buffer Embree returns has room
        // for exactly `len` items of `size_of::<T>()` bytes (the stride we
        // pass), and we copy that many items into it.
        unsafe {
            let geometry = GeometryGuard(sys::rtcNewGeometry(self.device, kind));
            check(self.device, "rtcNewGeometry")?;
            fill(
                geometry.0,
                sys::RTCBufferType::VERTEX,
                vertex_format,
                vertices,
            )
            .ok_or(EmbreeError {
                step: "vertex buffer",
                code: None,
            })?;
            check(self.device, "vertex buffer")?;
            if !indices.is_empty() {
                fill(geometry.0, sys::RTCBufferType::INDEX, index_format, indices).ok_or(
                    EmbreeError {
                        step: "index buffer",
                        code: None,
                    },
                )?;
                check(self.device, "index buffer")?;
            }
            if let Some(data) = filter {
                sys::rtcSetGeometryUserData(geometry.0, data);
                sys::rtcSetGeometryIntersectFilterFunction(geometry.0, Some(alpha_filter));
                check(self.device, "intersection filter")?;
            }
            sys::rtcCommitGeometry(geometry.0);
            check(self.device, "rtcCommitGeometry")?;
            let id = sys::rtcAttachGeometry(self.scene, geometry.0);
            check(self.device, "rtcAttachGeometry")?;
            if id as usize != self.prim_ids.len() {
                return Err(EmbreeError {
                    step: "geometry ids out of order",
                    code: None,
                });
            }
        }
        Ok(())
    }

    /// Embree's closest hit with `t_min < t < t_max`, or `None`.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<EmbreeHit> {
        let mut rayhit = sys::RTCRayHit {
            ray: sys::RTCRay {
                org_x: ray.origin.x,
                org_y: ray.origin.y,
                org_z: ray.origin.z,
                tnear: next_up(t_min.max(0.0)),
                dir_x: ray.direction.x,
                dir_y: ray.direction.y,
                dir_z: ray.direction.z,
                time: 0.0,
                // The open interval (t_min, t_max); an infinite t_max stays
                // infinite (Embree's "no limit").
                tfar: if t_max == f32::INFINITY {
                    t_max
                } else {
                    next_down(t_max)
                },
                mask: u32::MAX,
                id: 0,
                flags: 0,
            },
            hit: sys::RTCHit {
                Ng_x: 0.0,
                Ng_y: 0.0,
                Ng_z: 0.0,
                u: 0.0,
                v: 0.0,
                primID: sys::RTC_INVALID_GEOMETRY_ID,
                geomID: sys::RTC_INVALID_GEOMETRY_ID,
                instID: [sys::RTC_INVALID_GEOMETRY_ID],
            },
        };
        // SAFETY: the scene is committed; `rayhit` is a properly aligned
        // (repr(align(16))) RTCRayHit; null arguments select the defaults.
        unsafe { sys::rtcIntersect1(self.scene, &mut rayhit, ptr::null_mut()) };
        let h = &rayhit.hit;
        if h.geomID == sys::RTC_INVALID_GEOMETRY_ID {
            return None;
        }
        let prim = self.prim_ids[h.geomID as usize][h.primID as usize];
        Some(EmbreeHit {
            t: rayhit.ray.tfar,
            prim,
            uv: Vec2::new(h.u, h.v),
            ng: Vec3::new(h.Ng_x, h.Ng_y, h.Ng_z),
        })
    }

    /// The library's version string, e.g. `4.4.0`.
    pub fn version(&self) -> String {
        // SAFETY: the device is live; the property is a plain integer.
        let v = unsafe { sys::rtcGetDeviceProperty(self.device, sys::RTCDeviceProperty::VERSION) };
        format!("{}.{}.{}", v / 10000, (v / 100) % 100, v % 100)
    }
}

/// Copies `items` into a new geometry buffer; `None` if Embree returned no memory.
///
/// # Safety
/// `geometry` must be a live, uncommitted geometry handle.
unsafe fn fill<T: Copy>(
    geometry: sys::RTCGeometry,
    kind: sys::RTCBufferType,
    format: sys::RTCFormat,
    items: &[T],
) -> Option<()> {
    let dst = sys::rtcSetNewGeometryBuffer(geometry, kind, 0, format, size_of::<T>(), items.len());
    if dst.is_null() {
        return None;
    }
    ptr::copy_nonoverlapping(
        items.as_ptr() as *const c_void as *const u8,
        dst as *mut u8,
        std::mem::size_of_val(items),
    );
    Some(())
}

impl Drop for EmbreeScene {
    fn drop(&mut self) {
        // SAFETY: both handles are owned here and released once; the scene
        // (holding the geometries) before its device.
        unsafe {
            if !self.scene.is_null() {
                sys::rtcReleaseScene(self.scene);
            }
            sys::rtcReleaseDevice(self.device);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Material;
    use crate::scene::{SceneBuilder, Transform};

    /// Two triangles on one ray: the nearer one's material has a coverage
    /// of 0.25 (MASK: cut away at cutoff 0.5, kept at 0.25): Embree's filter
    /// lets the ray through to the farther one, or stops it, as the
    /// reference does.
    #[test]
    fn the_intersection_filter_cuts_what_the_reference_cuts() {
        use crate::material::{Alpha, AlphaMode};
        for (cutoff, expect) in [(0.5, 1u32), (0.25, 0)] {
            let mut b = SceneBuilder::new();
            let white = b.constant(Vec3::ONE).unwrap();
            let quarter = b.constant(Vec3::splat(0.25)).unwrap();
            let near = b
                .add_material(Material::Lambertian { albedo: white })
                .unwrap();
            let far = b
                .add_material(Material::Lambertian { albedo: white })
                .unwrap();
            b.set_alpha(
                near,
                Alpha {
                    texture: quarter,
                    mode: AlphaMode::Mask { cutoff },
                },
            )
            .unwrap();
            let id = Transform::default();
            for (z, m) in [(-2.0, near), (-4.0, far)] {
                let tri = crate::scene::MeshInput {
                    positions: vec![
                        Vec3::new(-1.0, -1.0, z),
                        Vec3::new(1.0, -1.0, z),
                        Vec3::new(0.0, 1.0, z),
                    ],
                    indices: vec![0, 1, 2],
                    ..Default::default()
                };
                b.add_mesh(&tri, m, &id).unwrap();
            }
            let scene = b.build().unwrap();
            let e = EmbreeScene::new(&scene).unwrap();
            let ray = Ray::new(Vec3::ZERO, -Vec3::Z);
            let embree = e.intersect(&ray, 0.0, f32::INFINITY).unwrap();
            let reference = scene.intersect(&ray, 0.0, f32::INFINITY).unwrap();
            assert_eq!(
                (embree.prim, reference.prim),
                (expect, expect),
                "cutoff {cutoff}"
            );
        }
    }

    #[test]
    fn one_of_each_shape_is_hit_with_reference_ids() {
        let mut b = SceneBuilder::new();
        let white = b.constant(Vec3::ONE).unwrap();
        let m = b
            .add_material(Material::Lambertian { albedo: white })
            .unwrap();
        let id = Transform::default();
        b.add_sphere(Vec3::new(0.0, 0.0, -5.0), -1.0, m, &id)
            .unwrap();
        b.add_quad(
            Vec3::new(2.0, -1.0, -5.0),
            Vec3::X * 2.0,
            Vec3::Y * 2.0,
            m,
            &id,
        )
        .unwrap();
        let tri = crate::scene::MeshInput {
            positions: vec![
                Vec3::new(-4.0, -1.0, -5.0),
                Vec3::new(-2.0, -1.0, -5.0),
                Vec3::new(-3.0, 1.0, -5.0),
            ],
            indices: vec![0, 1, 2],
            ..Default::default()
        };
        b.add_mesh(&tri, m, &id).unwrap();
        let scene = b.build().unwrap();
        let e = EmbreeScene::new(&scene).unwrap();
        assert!(e.version().starts_with("4."), "{}", e.version());
        for (x, prim, t) in [(0.0, 0u32, 4.0f32), (3.0, 1, 5.0), (-3.0, 2, 5.0)] {
            let ray = Ray::new(Vec3::new(x, 0.0, 0.0), -Vec3::Z);
            let h = e
                .intersect(&ray, 0.0, f32::INFINITY)
                .unwrap_or_else(|| panic!("x = {x}: no hit"));
            assert_eq!(h.prim, prim, "x = {x}");
            // Embree's t is within a few ulps of the exact answer (measured: 0.99999994 for 1).
            assert!(
                (h.t - t).abs() <= 4.0 * f32::EPSILON * t,
                "x = {x}: t = {}",
                h.t
            );
        }
        // From inside the sphere: the far side.
        let inside = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::Z);
        let h = e.intersect(&inside, 0.0, f32::INFINITY).unwrap();
        assert_eq!(h.prim, 0);
        assert!((h.t - 1.0).abs() < 1e-5);
        // The open interval: a hit exactly at t_max is not reported.
        assert!(e
            .intersect(&Ray::new(Vec3::new(3.0, 0.0, 0.0), -Vec3::Z), 0.0, 4.5)
            .is_none());
        assert!(e
            .intersect(
                &Ray::new(Vec3::new(9.0, 0.0, 0.0), -Vec3::Z),
                0.0,
                f32::INFINITY
            )
            .is_none());
    }
}
