//! Primitives as meshes: read once per primitive, tangents generated where
//! a normal map needs them, placed in world space and merged into one mesh.

use super::accessors::{read_floats, read_indices};
use super::bounds;
use super::document::GltfFile;
use super::materials::normal_map_set;
use crate::error::SceneError;
use crate::scene::{MeshInput, Transform};
use glam::{DAffine3, DMat3, Vec2, Vec3, Vec4};
use gltf::accessor::Dimensions;
use gltf::buffer::Data as BufferData;
use gltf::mesh::{Mode, Semantic};
use std::collections::HashMap;

/// Primitives read once, in their own space, however many nodes use them.
#[derive(Default)]
pub(super) struct MeshCache {
    meshes: HashMap<(usize, usize), Option<MeshInput>>,
}

impl MeshCache {
    /// The primitive's triangles (`None`: not triangles, or no triangles).
    pub(super) fn get(
        &mut self,
        file: &GltfFile,
        mesh: usize,
        primitive: &gltf::Primitive,
    ) -> Result<Option<&MeshInput>, SceneError> {
        let key = (mesh, primitive.index());
        let slot = match self.meshes.entry(key) {
            std::collections::hash_map::Entry::Occupied(slot) => slot.into_mut(),
            std::collections::hash_map::Entry::Vacant(slot) => {
                let read = read_primitive(primitive, &file.buffers).map_err(|m| {
                    let at = file
                        .document
                        .meshes()
                        .nth(mesh)
                        .map_or_else(|| format!("meshes[{mesh}]"), |mesh| mesh_named(&mesh));
                    file.error(format!("{at}: primitives[{}]: {m}", primitive.index()))
                })?;
                slot.insert(read.filter(|m| !m.indices.is_empty()))
            }
        };
        Ok(slot.as_ref())
    }
}

/// How errors and warnings name a mesh ([`bounds::named`]).
pub(super) fn mesh_named(mesh: &gltf::Mesh) -> String {
    bounds::named("mesh", &format!("meshes[{}]", mesh.index()), mesh.name())
}

/// Reads one primitive as indexed triangles in the mesh's own space.
fn read_primitive(
    primitive: &gltf::Primitive,
    buffers: &[BufferData],
) -> Result<Option<MeshInput>, String> {
    let mode = primitive.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        return Ok(None);
    }
    for (semantic, accessor) in primitive.attributes() {
        bounds::attribute(&semantic, &accessor)?;
    }
    let positions_accessor = primitive
        .get(&Semantic::Positions)
        .ok_or("no POSITION attribute")?;
    let positions: Vec<Vec3> =
        read_floats(&positions_accessor, buffers, "POSITION", Dimensions::Vec3)?
            .chunks_exact(3)
            .map(Vec3::from_slice)
            .collect();
    let n = positions.len();
    let normals = match primitive.get(&Semantic::Normals) {
        Some(a) => Some(
            read_floats(&a, buffers, "NORMAL", Dimensions::Vec3)?
                .chunks_exact(3)
                .map(Vec3::from_slice)
                .collect::<Vec<_>>(),
        ),
        None => None,
    };
    // A texture coordinate set, v flipped into the renderer's convention.
    let read_uvs = |set: u32| -> Result<Option<Vec<Vec2>>, String> {
        let Some(a) = primitive.get(&Semantic::TexCoords(set)) else {
            return Ok(None);
        };
        let name = format!("TEXCOORD_{set}");
        Ok(Some(
            read_floats(&a, buffers, &name, Dimensions::Vec2)?
                .chunks_exact(2)
                .map(|c| Vec2::new(c[0], 1.0 - c[1]))
                .collect(),
        ))
    };
    let (uvs, uvs1) = (read_uvs(0)?, read_uvs(1)?);
    let colors = match primitive.get(&Semantic::Colors(0)) {
        Some(a) => {
            let shape = match a.dimensions() {
                Dimensions::Vec3 => Dimensions::Vec3,
                _ => Dimensions::Vec4,
            };
            let floats = read_floats(&a, buffers, "COLOR_0", shape)?;
            Some(match shape {
                Dimensions::Vec3 => floats
                    .chunks_exact(3)
                    .map(|c| Vec3::from_slice(c).extend(1.0))
                    .collect::<Vec<_>>(),
                _ => floats.chunks_exact(4).map(Vec4::from_slice).collect(),
            })
        }
        None => None,
    };
    // Tangents without normals are to be ignored (glTF 2.0, "Meshes").
    let tangents = match (primitive.get(&Semantic::Tangents), &normals) {
        (Some(a), Some(_)) => Some(
            read_floats(&a, buffers, "TANGENT", Dimensions::Vec4)?
                .chunks_exact(4)
                .map(Vec4::from_slice)
                .collect::<Vec<_>>(),
        ),
        _ => None,
    };
    for (name, len) in [
        ("NORMAL", normals.as_ref().map(Vec::len)),
        ("TEXCOORD_0", uvs.as_ref().map(Vec::len)),
        ("TEXCOORD_1", uvs1.as_ref().map(Vec::len)),
        ("COLOR_0", colors.as_ref().map(Vec::len)),
        ("TANGENT", tangents.as_ref().map(Vec::len)),
    ] {
        if let Some(len) = len.filter(|&l| l != n) {
            return Err(format!("{name} has {len} elements but POSITION has {n}"));
        }
    }
    let vertices: Vec<u32> = match primitive.indices() {
        Some(a) => read_indices(&a, buffers)?,
        None => {
            let count = u32::try_from(n).map_err(|_| format!("{n} vertices are too many"))?;
            (0..count).collect()
        }
    };
    if let Some((i, &bad)) = vertices.iter().enumerate().find(|(_, &v)| v as usize >= n) {
        return Err(format!("index {i} is {bad}, out of range for {n} vertices"));
    }
    let indices = match mode {
        Mode::Triangles => {
            if !vertices.chunks_exact(3).remainder().is_empty() {
                return Err(format!(
                    "a triangle list with {} indices (not a multiple of 3)",
                    vertices.len()
                ));
            }
            vertices
        }
        // Strip triangle i: (v[i], v[i+1], v[i+2]) for even i, (v[i], v[i+2], v[i+1]) for odd i.
        Mode::TriangleStrip => (0..vertices.len().saturating_sub(2))
            .flat_map(|i| {
                if i % 2 == 0 {
                    [vertices[i], vertices[i + 1], vertices[i + 2]]
                } else {
                    [vertices[i], vertices[i + 2], vertices[i + 1]]
                }
            })
            .collect(),
        // Fan triangle i: (v[i+1], v[i+2], v[0]).
        _ => (0..vertices.len().saturating_sub(2))
            .flat_map(|i| [vertices[i + 1], vertices[i + 2], vertices[0]])
            .collect(),
    };
    let mut mesh = MeshInput {
        positions,
        normals,
        uvs,
        indices,
        colors,
        tangents,
        uvs1,
    };
    match normal_map_set(&primitive.material())? {
        // Tangents serve normal maps only.
        None => mesh.tangents = None,
        Some(set) if mesh.tangents.is_none() => mesh = with_generated_tangents(mesh, set),
        Some(_) => {}
    }
    Ok(Some(mesh))
}

/// `mesh` with MikkTSpace tangents (the algorithm glTF 2.0 names for files
/// without TANGENT) computed from its positions, its normals (the face
/// normal where it has none) and texture coordinate set `set` in the
/// renderer's convention (v up: the bitangent then points up the image,
/// the convention of glTF's normal maps). The algorithm gives each
/// triangle corner its own tangent; a vertex whose corners got different
/// ones (at a uv seam or mirror) is split, one copy per tangent. A mesh
/// with no coordinates of that set, or with non-finite values (which the
/// scene builder refuses anyway), is returned as it is: no tangents, no
/// normal mapping.
pub(super) fn with_generated_tangents(mesh: MeshInput, set: u32) -> MeshInput {
    let uvs = match set {
        0 => mesh.uvs.as_ref(),
        1 => mesh.uvs1.as_ref(),
        _ => None,
    };
    let Some(uvs) = uvs else { return mesh };
    let finite = mesh.positions.iter().all(|p| p.is_finite())
        && uvs.iter().all(|uv| uv.is_finite())
        && mesh.normals.iter().flatten().all(|n| n.is_finite());
    if !finite {
        return mesh;
    }
    struct Corners<'m> {
        mesh: &'m MeshInput,
        uvs: &'m [Vec2],
        tangents: Vec<Vec4>,
    }
    impl Corners<'_> {
        fn vertex(&self, face: usize, vert: usize) -> usize {
            self.mesh.indices[3 * face + vert] as usize
        }
    }
    impl mikktspace::Geometry for Corners<'_> {
        fn num_faces(&self) -> usize {
            self.mesh.indices.len() / 3
        }
        fn num_vertices_of_face(&self, _face: usize) -> usize {
            3
        }
        fn position(&self, face: usize, vert: usize) -> [f32; 3] {
            self.mesh.positions[self.vertex(face, vert)].to_array()
        }
        fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
            match &self.mesh.normals {
                Some(normals) => normals[self.vertex(face, vert)].to_array(),
                None => {
                    let [a, b, c] = [0, 1, 2].map(|v| self.mesh.positions[self.vertex(face, v)]);
                    (b - a).cross(c - a).normalize_or_zero().to_array()
                }
            }
        }
        fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
            self.uvs[self.vertex(face, vert)].to_array()
        }
        fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
            self.tangents[3 * face + vert] = Vec4::from_array(tangent);
        }
    }
    let mut corners = Corners {
        mesh: &mesh,
        uvs,
        tangents: vec![Vec4::ZERO; mesh.indices.len()],
    };
    if !mikktspace::generate_tangents(&mut corners) {
        return mesh;
    }
    let corner_tangents = corners.tangents;
    // Weld corners back: one vertex per (original vertex, tangent).
    let mut first_copy: HashMap<(u32, [u32; 4]), u32> = HashMap::new();
    let mut source: Vec<u32> = Vec::new();
    let mut tangents: Vec<Vec4> = Vec::new();
    let indices: Vec<u32> = mesh
        .indices
        .iter()
        .zip(&corner_tangents)
        .map(|(&v, t)| {
            *first_copy
                .entry((v, t.to_array().map(f32::to_bits)))
                .or_insert_with(|| {
                    source.push(v);
                    tangents.push(*t);
                    source.len() as u32 - 1
                })
        })
        .collect();
    let pick = |values: &Vec<Vec3>| source.iter().map(|&v| values[v as usize]).collect();
    let pick2 = |values: &Vec<Vec2>| source.iter().map(|&v| values[v as usize]).collect();
    MeshInput {
        positions: pick(&mesh.positions),
        normals: mesh.normals.as_ref().map(pick),
        uvs: mesh.uvs.as_ref().map(pick2),
        uvs1: mesh.uvs1.as_ref().map(pick2),
        colors: mesh
            .colors
            .as_ref()
            .map(|c| source.iter().map(|&v| c[v as usize]).collect()),
        tangents: Some(tangents),
        indices,
    }
}

pub(super) fn flip_winding(indices: &mut [u32]) {
    for tri in indices.chunks_exact_mut(3) {
        tri.swap(1, 2);
    }
}

/// The primitive in world space (winding reversed under a mirroring matrix).
pub(super) fn place(local: &MeshInput, world: &DAffine3) -> MeshInput {
    let transform = Transform { matrix: *world };
    let normal_matrix = transform.normal_matrix();
    let mut indices = local.indices.clone();
    if transform.mirrors() {
        flip_winding(&mut indices);
    }
    MeshInput {
        positions: local
            .positions
            .iter()
            .map(|&p| transform.point(p))
            .collect(),
        // Under a pure translation the normals are kept bit for bit.
        normals: local.normals.as_ref().map(|ns| {
            if world.matrix3 == DMat3::IDENTITY {
                ns.clone()
            } else {
                ns.iter()
                    .map(|&n| (normal_matrix * n).normalize_or_zero())
                    .collect()
            }
        }),
        uvs: local.uvs.clone(),
        indices,
        ..MeshInput::default()
    }
}

/// Unwelds a mesh into three vertices per triangle carrying its face normal.
fn flat_shaded(mesh: MeshInput) -> MeshInput {
    let mut out = MeshInput {
        positions: Vec::new(),
        normals: Some(Vec::new()),
        uvs: mesh.uvs.as_ref().map(|_| Vec::new()),
        ..MeshInput::default()
    };
    let normals = out.normals.get_or_insert_with(Vec::new);
    for (t, tri) in mesh.indices.chunks_exact(3).enumerate() {
        let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| mesh.positions[i as usize]);
        let n = (b - a).cross(c - a).normalize_or_zero();
        for &i in tri {
            out.positions.push(mesh.positions[i as usize]);
            normals.push(n);
            if let (Some(dst), Some(src)) = (out.uvs.as_mut(), mesh.uvs.as_ref()) {
                dst.push(src[i as usize]);
            }
        }
        let base = 3 * t as u32;
        out.indices.extend([base, base + 1, base + 2]);
    }
    out
}

/// Concatenates placed primitives into one mesh (see
/// [`load_gltf_mesh`](super::import::load_gltf_mesh)).
pub(super) fn merge(parts: Vec<MeshInput>) -> Result<MeshInput, String> {
    let any_normals = parts.iter().any(|p| p.normals.is_some());
    let any_uvs = parts.iter().any(|p| p.uvs.is_some());
    let mut out = MeshInput {
        positions: Vec::new(),
        normals: any_normals.then(Vec::new),
        uvs: any_uvs.then(Vec::new),
        ..MeshInput::default()
    };
    for part in parts {
        let part = if any_normals && part.normals.is_none() {
            flat_shaded(part)
        } else {
            part
        };
        if out.positions.len() + part.positions.len() > u32::MAX as usize {
            return Err("the merged mesh has more than 2^32 vertices".into());
        }
        let base = out.positions.len() as u32;
        out.indices.extend(part.indices.iter().map(|&i| base + i));
        if let Some(normals) = out.normals.as_mut() {
            normals.extend(part.normals.iter().flatten());
        }
        if let Some(uvs) = out.uvs.as_mut() {
            match &part.uvs {
                Some(src) => uvs.extend(src),
                None => uvs.extend(std::iter::repeat_n(Vec2::ZERO, part.positions.len())),
            }
        }
        out.positions.extend(part.positions);
    }
    Ok(out)
}
