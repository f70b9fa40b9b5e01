//! Deterministic procedural meshes, for fixtures and for watertightness
//! stress tests, and a minimal GLB writer to store them.
//!
//! Every mesh here is closed and consistently wound: vertices are shared
//! (each edge is used by exactly two triangles, once in each direction),
//! and triangles are counter-clockwise seen from outside, so the geometric
//! normal `(b - a) × (c - a)` points out. The same arguments give the same
//! bits on every run (no randomness, no dependence on hash-map iteration
//! order). [`icosphere`] uses only correctly rounded IEEE operations (+, ×,
//! ÷, √), so its bits are the same on every platform; [`torus`] and
//! [`bumpy_sphere`] also call `sin`/`cos`, which come from the platform's
//! math library and may differ in the last bit elsewhere.
//!
//! [`write_glb`] stores a [`MeshInput`] as a glTF 2.0 binary that
//! [`crate::loader::gltf::load_gltf_mesh`] reads back exactly (texture `v`
//! is flipped to glTF's top-left origin on the way out and back on the
//! way in; that is exact for multiples of 2⁻²⁴ in [0, 1], and otherwise
//! off by at most the rounding of `1 - v`, 2⁻²⁵ for `v` in [0, 1]).

use crate::scene::MeshInput;
use glam::{Vec2, Vec3};
use std::collections::HashMap;
use std::io::{self, Write};
use std::path::Path;

/// Subdivision levels above this are clamped (20·4¹⁰ ≈ 2·10⁷ triangles).
pub const MAX_SUBDIVISIONS: u32 = 10;
/// Torus segment counts are clamped to `[3, MAX_TORUS_SEGMENTS]`.
pub const MAX_TORUS_SEGMENTS: u32 = 4096;

/// The unit icosphere: an icosahedron whose triangles are split
/// `subdivisions` times into four, new vertices pushed onto the sphere.
/// `20·4^k` triangles, `10·4^k + 2` shared vertices; normals equal the
/// positions; no texture coordinates (a seam would need split vertices).
/// `subdivisions` is clamped to [`MAX_SUBDIVISIONS`].
pub fn icosphere(subdivisions: u32) -> MeshInput {
    let (mut positions, mut triangles) = icosahedron();
    for _ in 0..subdivisions.min(MAX_SUBDIVISIONS) {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| -> u32 {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push((positions[a as usize] + positions[b as usize]).normalize());
                positions.len() as u32 - 1
            })
        };
        let mut finer = Vec::with_capacity(triangles.len() * 4);
        for &[a, b, c] in &triangles {
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            finer.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = finer;
    }
    MeshInput {
        normals: Some(positions.clone()),
        positions,
        uvs: None,
        indices: triangles.into_iter().flatten().collect(),
        ..MeshInput::default()
    }
}

/// The 12 unit vertices and 20 outward-wound faces of a regular icosahedron.
fn icosahedron() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let phi = (1.0 + 5.0f32.sqrt()) / 2.0;
    let mut corners = Vec::with_capacity(12);
    for s in [-1.0, 1.0] {
        for t in [-1.0, 1.0] {
            // The cyclic permutations of (0, ±1, ±φ).
            corners.push(Vec3::new(0.0, s, t * phi));
            corners.push(Vec3::new(s, t * phi, 0.0));
            corners.push(Vec3::new(t * phi, 0.0, s));
        }
    }
    // Faces are the triples of mutually adjacent corners (edge length 2).
    let adjacent =
        |i: usize, j: usize| (corners[i].distance_squared(corners[j]) - 4.0).abs() < 1e-3;
    let mut faces = Vec::with_capacity(20);
    for i in 0..12 {
        for j in i + 1..12 {
            for k in j + 1..12 {
                if adjacent(i, j) && adjacent(j, k) && adjacent(i, k) {
                    let (a, b, c) = (corners[i], corners[j], corners[k]);
                    let outward = (b - a).cross(c - a).dot(a + b + c) > 0.0;
                    faces.push(if outward {
                        [i as u32, j as u32, k as u32]
                    } else {
                        [i as u32, k as u32, j as u32]
                    });
                }
            }
        }
    }
    (corners.into_iter().map(Vec3::normalize).collect(), faces)
}

/// A ring torus around the y axis: tube centre circle of radius `major` in
/// the xz plane, tube radius `minor`. `segments_major` steps around y,
/// `segments_minor` around the tube (each clamped to `[3,
/// MAX_TORUS_SEGMENTS]`); the seams share their vertices, so the mesh is
/// closed. `2·segments_major·segments_minor` triangles, unit normals of the
/// ideal torus. With `minor >= major` the surface intersects itself (still
/// closed and consistently wound).
pub fn torus(major: f32, minor: f32, segments_major: u32, segments_minor: u32) -> MeshInput {
    let (n, m) = (
        segments_major.clamp(3, MAX_TORUS_SEGMENTS),
        segments_minor.clamp(3, MAX_TORUS_SEGMENTS),
    );
    let mut positions = Vec::with_capacity((n * m) as usize);
    let mut normals = Vec::with_capacity((n * m) as usize);
    for i in 0..n {
        let u = std::f32::consts::TAU * i as f32 / n as f32;
        let (su, cu) = u.sin_cos();
        for j in 0..m {
            let v = std::f32::consts::TAU * j as f32 / m as f32;
            let (sv, cv) = v.sin_cos();
            let ring = major + minor * cv;
            positions.push(Vec3::new(ring * cu, minor * sv, ring * su));
            normals.push(Vec3::new(cv * cu, sv, cv * su).normalize());
        }
    }
    let id = |i: u32, j: u32| (i % n) * m + (j % m);
    let mut indices = Vec::with_capacity((6 * n * m) as usize);
    for i in 0..n {
        for j in 0..m {
            // (∂P/∂v) × (∂P/∂u) points out of the tube.
            let (a, b, c, d) = (id(i, j), id(i, j + 1), id(i + 1, j + 1), id(i + 1, j));
            indices.extend([a, b, c, a, c, d]);
        }
    }
    MeshInput {
        positions,
        normals: Some(normals),
        uvs: None,
        indices,
        ..MeshInput::default()
    }
}

/// An icosphere displaced along its normals by `amplitude · f(p)`, where
/// `f` is a smooth function in [-1, 1]: the mean of three phase-shifted
/// sines of `frequency` times each coordinate. Vertex normals are the
/// normalized sums of the adjacent faces' area-weighted normals. Keep
/// `|amplitude| < 1` for the surface to stay star-shaped (and embedded).
pub fn bumpy_sphere(subdivisions: u32, amplitude: f32, frequency: f32) -> MeshInput {
    let mut mesh = icosphere(subdivisions);
    for p in &mut mesh.positions {
        let bump = ((frequency * p.x + 1.3).sin()
            + (frequency * p.y + 2.1).sin()
            + (frequency * p.z + 0.7).sin())
            / 3.0;
        *p *= 1.0 + amplitude * bump;
    }
    mesh.normals = Some(area_weighted_normals(&mesh.positions, &mesh.indices));
    mesh
}

/// Per-vertex normals: the normalized sum of `(b - a) × (c - a)` (twice the
/// area times the unit normal) over the triangles using each vertex. A
/// vertex used only by degenerate triangles gets a zero normal.
pub fn area_weighted_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut sums = vec![Vec3::ZERO; positions.len()];
    for tri in indices.chunks_exact(3) {
        let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in tri {
            sums[i as usize] += n;
        }
    }
    sums.into_iter().map(Vec3::normalize_or_zero).collect()
}

/// glTF constants used by the writer.
mod gl {
    pub const FLOAT: u32 = 5126;
    pub const UNSIGNED_INT: u32 = 5125;
    pub const ARRAY_BUFFER: u32 = 34962;
    pub const ELEMENT_ARRAY_BUFFER: u32 = 34963;
}

/// Writes `mesh` as a glTF 2.0 binary (`.glb`): one buffer, one mesh with
/// one triangle primitive (POSITION with its min/max, NORMAL and
/// TEXCOORD_0 when present, UNSIGNED_INT indices), one node, one scene,
/// no material. Texture coordinates are stored in glTF's convention
/// (`v_gltf = 1 - v`). The file is written beside `path` under a temporary
/// name and renamed into place, so readers never see a partial file.
/// An empty mesh, non-finite positions, out-of-range indices or attribute
/// arrays of the wrong length are `InvalidInput` errors.
pub fn write_glb(path: &Path, mesh: &MeshInput) -> io::Result<()> {
    let bytes = glb_bytes(mesh)?;
    let invalid = |m: &str| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{}: {m}", path.display()),
        )
    };
    let name = path
        .file_name()
        .ok_or_else(|| invalid("the path has no file name"))?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let unique = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = dir.join(format!(
        ".{}.{}-{unique}.tmp",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| {
        let mut file = std::fs::File::create(&tmp)?;
        file.write_all(&bytes)?;
        file.sync_all()?;
        drop(file);
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// The GLB container bytes for `mesh` (see [`write_glb`]).
pub fn glb_bytes(mesh: &MeshInput) -> io::Result<Vec<u8>> {
    let invalid = |m: String| io::Error::new(io::ErrorKind::InvalidInput, m);
    let n = mesh.positions.len();
    if n == 0 || mesh.indices.is_empty() || !mesh.indices.chunks_exact(3).remainder().is_empty() {
        return Err(invalid(format!(
            "a mesh needs vertices and whole triangles ({n} vertices, {} indices)",
            mesh.indices.len()
        )));
    }
    if let Some(bad) = mesh.indices.iter().find(|&&i| i as usize >= n) {
        return Err(invalid(format!(
            "index {bad} is out of range for {n} vertices"
        )));
    }
    if n > u32::MAX as usize {
        return Err(invalid(format!(
            "{n} vertices are too many for 32-bit indices"
        )));
    }
    for (name, len) in [
        ("normals", mesh.normals.as_ref().map(Vec::len)),
        ("uvs", mesh.uvs.as_ref().map(Vec::len)),
    ] {
        if let Some(len) = len.filter(|&l| l != n) {
            return Err(invalid(format!("{len} {name} for {n} vertices")));
        }
    }
    if let Some(p) = mesh.positions.iter().find(|p| !p.is_finite()) {
        return Err(invalid(format!("position {p} is not finite")));
    }

    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut attributes = serde_json::Map::new();
    // Every block is a multiple of 4 bytes, so all views stay 4-aligned.
    let mut add_view = |bin: &mut Vec<u8>, data: Vec<u8>, target: u32| -> usize {
        views.push(serde_json::json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": data.len(), "target": target }));
        bin.extend(data);
        views.len() - 1
    };
    let floats = |values: &mut dyn Iterator<Item = f32>| -> Vec<u8> {
        values.flat_map(f32::to_le_bytes).collect()
    };

    let (min, max) = mesh
        .positions
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    let view = add_view(
        &mut bin,
        floats(&mut mesh.positions.iter().flat_map(|p| p.to_array())),
        gl::ARRAY_BUFFER,
    );
    accessors
        .push(serde_json::json!({ "bufferView": view, "componentType": gl::FLOAT, "count": n, "type": "VEC3", "min": min.to_array(), "max": max.to_array() }));
    attributes.insert("POSITION".into(), (accessors.len() - 1).into());
    if let Some(normals) = &mesh.normals {
        let view = add_view(
            &mut bin,
            floats(&mut normals.iter().flat_map(|v| v.to_array())),
            gl::ARRAY_BUFFER,
        );
        accessors.push(serde_json::json!({ "bufferView": view, "componentType": gl::FLOAT, "count": n, "type": "VEC3" }));
        attributes.insert("NORMAL".into(), (accessors.len() - 1).into());
    }
    if let Some(uvs) = &mesh.uvs {
        let view = add_view(
            &mut bin,
            floats(&mut uvs.iter().flat_map(|uv: &Vec2| [uv.x, 1.0 - uv.y])),
            gl::ARRAY_BUFFER,
        );
        accessors.push(serde_json::json!({ "bufferView": view, "componentType": gl::FLOAT, "count": n, "type": "VEC2" }));
        attributes.insert("TEXCOORD_0".into(), (accessors.len() - 1).into());
    }
    let view = add_view(
        &mut bin,
        mesh.indices.iter().flat_map(|i| i.to_le_bytes()).collect(),
        gl::ELEMENT_ARRAY_BUFFER,
    );
    accessors.push(serde_json::json!({ "bufferView": view, "componentType": gl::UNSIGNED_INT, "count": mesh.indices.len(), "type": "SCALAR" }));
    let indices = accessors.len() - 1;

    let document = serde_json::json!({
        "asset": { "version": "2.0", "generator": "twintrace" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": attributes, "indices": indices, "mode": 4 }] }],
        "buffers": [{ "byteLength": bin.len() }],
        "bufferViews": views,
        "accessors": accessors,
    });
    glb_container(&document, bin)
}

/// A GLB file of `document` (its one buffer's `byteLength` must be
/// `bin`'s length padded to 4) and the binary chunk `bin`.
pub fn glb_container(document: &serde_json::Value, mut bin: Vec<u8>) -> io::Result<Vec<u8>> {
    let mut json = serde_json::to_vec(document).map_err(io::Error::other)?;
    json.resize(json.len().next_multiple_of(4), b' ');
    bin.resize(bin.len().next_multiple_of(4), 0);
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let total = u32::try_from(total).map_err(|_| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{total} bytes exceed the GLB size limit of 4 GiB"),
        )
    })?;
    let mut out = Vec::with_capacity(total as usize);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend(total.to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::loader::gltf::load_gltf_mesh;
    use std::collections::HashSet;

    /// Each directed edge appears exactly once and its reverse exists: every
    /// edge is shared by two triangles that wind it oppositely.
    fn assert_closed(mesh: &MeshInput, what: &str) {
        let mut directed = HashSet::new();
        for t in mesh.indices.chunks_exact(3) {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                assert_ne!(a, b, "{what}: degenerate edge");
                assert!(
                    directed.insert((a, b)),
                    "{what}: directed edge ({a}, {b}) used twice"
                );
            }
        }
        for &(a, b) in &directed {
            assert!(
                directed.contains(&(b, a)),
                "{what}: edge ({a}, {b}) is a border"
            );
        }
    }

    /// Divergence theorem: a closed, outward-wound mesh encloses a positive volume.
    fn signed_volume(mesh: &MeshInput) -> f64 {
        mesh.indices
            .chunks_exact(3)
            .map(|t| {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| mesh.positions[i as usize].as_dvec3());
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    fn assert_unit_normals(mesh: &MeshInput, what: &str) {
        let normals = mesh.normals.as_ref().expect("normals");
        assert_eq!(normals.len(), mesh.positions.len());
        for n in normals {
            assert!(
                (n.length() - 1.0).abs() < 1e-5,
                "{what}: normal {n} is not unit length"
            );
        }
    }

    #[test]
    fn icosphere_counts_closure_and_orientation() {
        for k in 0..5 {
            let m = icosphere(k);
            assert_eq!(
                m.indices.len() / 3,
                20 * 4usize.pow(k),
                "triangles at level {k}"
            );
            assert_eq!(
                m.positions.len(),
                10 * 4usize.pow(k) + 2,
                "vertices at level {k}"
            );
            assert_closed(&m, &format!("icosphere({k})"));
            assert_unit_normals(&m, "icosphere");
            for t in m.indices.chunks_exact(3) {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| m.positions[i as usize]);
                assert!(
                    (b - a).cross(c - a).dot(a + b + c) > 0.0,
                    "icosphere({k}): a face winds inward"
                );
            }
            for (p, n) in m.positions.iter().zip(m.normals.as_ref().unwrap()) {
                assert_eq!(p, n);
            }
        }
        // Volume approaches the ball's 4π/3 from below.
        let v = signed_volume(&icosphere(4));
        assert!(
            v > 4.12 && v < 4.0 * std::f64::consts::PI / 3.0,
            "volume {v}"
        );
        assert_eq!(icosphere(3), icosphere(3), "deterministic");
    }

    #[test]
    fn torus_is_closed_and_outward() {
        for (n, m) in [(3, 3), (16, 8), (48, 24)] {
            let t = torus(2.0, 0.5, n, m);
            assert_eq!(t.indices.len() / 3, 2 * (n * m) as usize);
            assert_closed(&t, &format!("torus({n}, {m})"));
            assert_unit_normals(&t, "torus");
            // Every face's geometric normal agrees with its vertices' normals.
            let normals = t.normals.as_ref().unwrap();
            for tri in t.indices.chunks_exact(3) {
                let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| t.positions[i as usize]);
                let shading: Vec3 = tri.iter().map(|&i| normals[i as usize]).sum();
                assert!((b - a).cross(c - a).dot(shading) > 0.0);
            }
        }
        // 2π²Rr² for the ideal torus.
        let v = signed_volume(&torus(2.0, 0.5, 128, 64));
        let ideal = 2.0 * std::f64::consts::PI.powi(2) * 2.0 * 0.25;
        assert!((v / ideal - 1.0).abs() < 0.01, "volume {v} vs {ideal}");
        assert_closed(&torus(1.0, 0.2, 0, 1), "clamped torus");
    }

    #[test]
    fn bumpy_sphere_is_closed_and_displaced() {
        let m = bumpy_sphere(4, 0.08, 6.0);
        assert_closed(&m, "bumpy sphere");
        assert_unit_normals(&m, "bumpy sphere");
        let radii: Vec<f32> = m.positions.iter().map(|p| p.length()).collect();
        let (lo, hi) = radii
            .iter()
            .fold((f32::MAX, 0.0f32), |(lo, hi), &r| (lo.min(r), hi.max(r)));
        assert!(
            lo >= 0.92 - 1e-5 && hi <= 1.08 + 1e-5 && hi - lo > 0.05,
            "radii in [{lo}, {hi}]"
        );
        assert!(signed_volume(&m) > 0.0);
        // Normals point away from the centre (the bumps are gentle).
        for (p, n) in m.positions.iter().zip(m.normals.as_ref().unwrap()) {
            assert!(p.dot(*n) > 0.0);
        }
        assert_eq!(m, bumpy_sphere(4, 0.08, 6.0), "deterministic");
    }

    #[test]
    fn glb_round_trips_through_the_gltf_loader() {
        let dir = tempfile::tempdir().unwrap();
        let mut mesh = bumpy_sphere(2, 0.1, 5.0);
        // Dyadic texture coordinates survive the v flip exactly.
        mesh.uvs = Some(
            (0..mesh.positions.len())
                .map(|i| Vec2::new((i % 64) as f32 / 64.0, (i % 37) as f32 / 256.0))
                .collect(),
        );
        let path = dir.path().join("sphere.glb");
        write_glb(&path, &mesh).unwrap();
        let back = load_gltf_mesh(&path).unwrap();
        assert_eq!(back, mesh);
        let leftovers: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(
            leftovers,
            vec![std::ffi::OsString::from("sphere.glb")],
            "no temporary file is left behind"
        );

        // Without normals and uvs; arbitrary uvs come back within 2^-24.
        let plain = MeshInput {
            normals: None,
            ..icosphere(1)
        };
        write_glb(&path, &plain).unwrap();
        assert_eq!(load_gltf_mesh(&path).unwrap(), plain);
        let odd_uvs = MeshInput {
            uvs: Some(
                plain
                    .positions
                    .iter()
                    .map(|p| Vec2::new(p.x, 0.1 + 0.3 * p.y.abs()))
                    .collect(),
            ),
            ..plain.clone()
        };
        write_glb(&path, &odd_uvs).unwrap();
        for (a, b) in load_gltf_mesh(&path)
            .unwrap()
            .uvs
            .unwrap()
            .iter()
            .zip(odd_uvs.uvs.as_ref().unwrap())
        {
            assert!(
                (a.x - b.x).abs() == 0.0 && (a.y - b.y).abs() <= 1.0 / (1 << 24) as f32,
                "{a} vs {b}"
            );
        }

        // The container is 4-byte aligned and says so in its header.
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[..4], b"glTF");
        assert_eq!(
            u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize,
            bytes.len()
        );
        assert_eq!(bytes.len() % 4, 0);
    }

    #[test]
    fn glb_writer_rejects_invalid_meshes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.glb");
        let good = icosphere(0);
        let bad = [
            MeshInput::default(),
            MeshInput {
                indices: vec![0, 1, 99],
                ..good.clone()
            },
            MeshInput {
                indices: vec![0, 1],
                ..good.clone()
            },
            MeshInput {
                normals: Some(vec![Vec3::Z]),
                ..good.clone()
            },
            MeshInput {
                positions: {
                    let mut p = good.positions.clone();
                    p[3] = Vec3::NAN;
                    p
                },
                ..good.clone()
            },
        ];
        for mesh in bad {
            let err = write_glb(&path, &mesh).unwrap_err();
            assert_eq!(err.kind(), io::ErrorKind::InvalidInput, "{err}");
        }
        assert!(!path.exists());
    }
}
