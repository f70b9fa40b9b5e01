//! Packs a `reference::Scene` into GPU records. The BVH node array is
//! uploaded as the reference built it (the one BVH), or in the wide or
//! brute-force form of the same tree that another walk reads
//! (`crate::traversal`), its leaves' entries indexed or, for the inline
//! layouts, copied from the packed records ([`inline_entries`]).

use crate::bindings::{self, Binding};
use crate::records::*;
use crate::traversal::{INLINE_ALPHA, INLINE_TAG_SHIFT, INLINE_WORDS};
use crate::variants::{LeafLayout, NodeLayout, Traversal};
use reference::background::Background;
use reference::light::LightSet;
use reference::material::{Alpha, AlphaMode, Material, Wrappers};
use reference::texture::{Sampler, Texture};
use reference::Scene;

/// The scene as flat record arrays, ready to upload.
#[derive(Clone, Debug, Default)]
pub struct PackedScene {
    /// The walk `nodes` and `leaf_entries` are for (`crate::traversal`).
    pub traversal: Traversal,
    /// How `leaf_entries` holds the leaves' primitives.
    pub leaves: LeafLayout,
    /// Why `traversal` or `leaves` is not what was asked for, where it is
    /// not (the wide records of a pathological tree:
    /// [`crate::traversal::arrays`]; inline entries of more than 2^29
    /// primitives).
    pub traversal_note: Option<String>,
    /// The walk's records ([`crate::traversal::arrays`]), uploaded as
    /// `node_layout` says; for the compressed walk, the binary root's
    /// record alone, before [`Self::compressed`].
    pub nodes: Vec<reference::bvh::BvhNode>,
    /// The compressed walk's nodes (`crate::compressed`); empty for the
    /// other walks.
    pub compressed: Vec<crate::compressed::CompressedNode>,
    pub node_layout: NodeLayout,
    /// The leaves' entries in the tree's primitive order, as `leaves`
    /// says ([`crate::traversal::indexed_entries`],
    /// [`inline_entries`]).
    pub leaf_entries: Vec<[u32; 4]>,
    pub primitives: Vec<GpuPrimitive>,
    pub spheres: Vec<GpuSphere>,
    pub quads: Vec<GpuQuad>,
    pub quadrics: Vec<GpuQuadric>,
    pub triangles: Vec<GpuTriangle>,
    pub vertices: Vec<GpuVertex>,
    /// Empty when no triangle has colours, tangents or a second uv set.
    pub vertex_extras: Vec<GpuVertexExtra>,
    pub materials: Vec<GpuMaterial>,
    pub textures: Vec<GpuTexture>,
    pub images: Vec<GpuImage>,
    pub texels: Vec<f32>,
    /// The light set (`reference::light::LightSet`), built on the host.
    pub emitters: Vec<GpuEmitter>,
    pub light_densities: Vec<GpuLightDensity>,
    /// The environment light's selection probability (0: none) and where
    /// its tables start in `texels` (after the images': row CDF, column
    /// CDFs, cell densities, as `reference::light::EnvLight` holds them).
    pub env_pmf: f32,
    pub env_table: u32,
    /// Of `emitters`: the MIS estimator's light set (`LightSet::new`),
    /// the first `emitter_count`; then the BSDF estimator's
    /// (`LightSet::punctual_only`), `punctual_count` of them.
    pub emitter_count: u32,
    pub punctual_count: u32,
    /// Where the punctual lights' records (`GpuPunctualLight`) start in
    /// `texels`.
    pub punctual_table: u32,
    /// Where the pixel filter's sampling table
    /// (`reference::filter::FilterTable::to_words`) starts in `texels`;
    /// [`NO_FILTER_TABLE`] for the box.
    pub filter_table: u32,
}

/// A material's record with its coverage (`alpha`) and the texture of its
/// emission (`emission`, `reference::Scene::emission`), where it has them.
pub fn pack_material(m: &Material, alpha: Option<Alpha>, emission: Option<u32>) -> GpuMaterial {
    let (alpha_texture, alpha_cutoff) = match alpha {
        None => (NO_TEXTURE, 0.0),
        Some(Alpha {
            texture,
            mode: AlphaMode::Mask { cutoff },
        }) => (texture, cutoff.max(0.0)),
        Some(Alpha {
            texture,
            mode: AlphaMode::Blend,
        }) => (texture, ALPHA_BLEND),
    };
    let record = pack_bsdf(m);
    // The principled parameters' textures: none on another model.
    let principled = |t: u32| {
        if matches!(m, Material::Principled { .. }) {
            t
        } else {
            NO_TEXTURE
        }
    };
    GpuMaterial {
        alpha_texture,
        alpha_cutoff,
        emission: emission.unwrap_or(NO_TEXTURE),
        // No mask, normal map or blend ([`pack_wrappers`] puts them).
        opacity: NO_TEXTURE,
        normal_map: NO_TEXTURE,
        blend_weight: NO_TEXTURE,
        blend_second: NO_TEXTURE,
        pr_roughness: principled(record.pr_roughness),
        pr_anisotropic: principled(record.pr_anisotropic),
        pr_spec_trans: principled(record.pr_spec_trans),
        pr_metallic: principled(record.pr_metallic),
        pr_clearcoat: principled(record.pr_clearcoat),
        pr_clearcoat_gloss: principled(record.pr_clearcoat_gloss),
        pr_sheen: principled(record.pr_sheen),
        pr_sheen_tint: principled(record.pr_sheen_tint),
        pr_flatness: principled(record.pr_flatness),
        pr_spec_tint: principled(record.pr_spec_tint),
        pr_diff_trans: principled(record.pr_diff_trans),
        alpha_v: match m {
            Material::RoughConductor { .. } | Material::RoughDielectric { .. } => record.alpha_v,
            _ => NO_TEXTURE,
        },
        ..record
    }
}

/// A material's record under Mitsuba's wrappers (`wrappers`): its mask's
/// texture, its one side, its normal map and its blend.
pub fn pack_wrappers(record: GpuMaterial, wrappers: Wrappers) -> GpuMaterial {
    GpuMaterial {
        blend_weight: wrappers.blend.map_or(NO_TEXTURE, |b| b.weight),
        blend_second: wrappers.blend.map_or(NO_TEXTURE, |b| b.second),
        opacity: wrappers.opacity.unwrap_or(NO_TEXTURE),
        one_sided: wrappers.one_sided as u32,
        normal_map: wrappers.normal_map.unwrap_or(NO_TEXTURE),
        normal_map_mode: if wrappers.normal_map_mirrored {
            crate::records::NORMAL_MAP_MIRRORED
        } else {
            0
        } | if wrappers.bump_map {
            crate::records::NORMAL_MAP_BUMP
        } else {
            0
        },
        ..record
    }
}

/// Sets each material's `shade_bucket`, the run of a bounce's paths the
/// sorted wavefront (`ShadeOrder::Material`) shades it in: the materials
/// ranked by kind (their tag), then by index, and the ranks spread evenly
/// over the first `SORT_BUCKETS - 1` buckets (the last holds the paths that
/// hit nothing or only finish a shadow ray). Up to 63 materials get a
/// bucket each; more share buckets with their neighbours in rank, so that
/// one bucket holds one kind but where two kinds meet.
pub fn assign_shade_buckets(mut materials: Vec<GpuMaterial>) -> Vec<GpuMaterial> {
    let buckets = crate::records::SORT_BUCKETS as u64 - 1;
    let mut ranked: Vec<usize> = (0..materials.len()).collect();
    ranked.sort_by_key(|&i| (materials[i].tag, i));
    let n = materials.len().max(1) as u64;
    for (rank, i) in ranked.into_iter().enumerate() {
        materials[i].shade_bucket = (rank as u64 * buckets / n) as u32;
    }
    materials
}

fn pack_bsdf(m: &Material) -> GpuMaterial {
    let tag = m.tag();
    match *m {
        Material::Lambertian { albedo } => GpuMaterial {
            tag,
            texture: albedo,
            ..Default::default()
        },
        Material::Metal { albedo, fuzz } => GpuMaterial {
            tag,
            texture: albedo,
            p0: fuzz,
            ..Default::default()
        },
        Material::Dielectric { ior, absorption } => GpuMaterial {
            tag,
            p0: ior,
            absorption_r: absorption.x,
            absorption_g: absorption.y,
            absorption_b: absorption.z,
            ..Default::default()
        },
        Material::SmoothDielectric {
            eta,
            reflectance,
            transmittance,
        }
        | Material::ThinDielectric {
            eta,
            reflectance,
            transmittance,
        } => GpuMaterial {
            tag,
            texture: reflectance,
            texture2: transmittance,
            p0: eta,
            ..Default::default()
        },
        Material::Conductor { specular, eta, k } => GpuMaterial {
            tag,
            texture: specular,
            p0: eta.x,
            p1: eta.y,
            p2: eta.z,
            absorption_r: k.x,
            absorption_g: k.y,
            absorption_b: k.z,
            ..Default::default()
        },
        Material::RoughConductor {
            distribution,
            alpha,
            alpha_v,
            specular,
            eta,
            k,
        } => GpuMaterial {
            tag,
            texture2: alpha,
            alpha_v: alpha_v.unwrap_or(NO_TEXTURE),
            distribution,
            ..pack_bsdf(&Material::Conductor { specular, eta, k })
        },
        Material::RoughDielectric {
            distribution,
            alpha,
            alpha_v,
            eta,
            reflectance,
            transmittance,
        } => GpuMaterial {
            tag,
            texture: reflectance,
            texture2: alpha,
            alpha_v: alpha_v.unwrap_or(NO_TEXTURE),
            texture3: transmittance,
            p0: eta,
            distribution,
            ..Default::default()
        },
        Material::Plastic {
            diffuse,
            specular,
            eta,
            nonlinear,
            specular_weight,
        } => GpuMaterial {
            tag,
            texture: diffuse,
            texture3: specular,
            p0: eta,
            p1: reference::material::plastic_internal_reflectance(eta),
            p2: specular_weight,
            absorption_r: if nonlinear { 1.0 } else { 0.0 },
            ..Default::default()
        },
        Material::RoughPlastic {
            distribution,
            alpha,
            diffuse,
            specular,
            eta,
            nonlinear,
            specular_weight,
            transmittance,
            internal,
        } => GpuMaterial {
            tag,
            texture: diffuse,
            texture2: transmittance,
            texture3: specular,
            p0: eta,
            p1: internal,
            p2: specular_weight,
            absorption_r: if nonlinear { 1.0 } else { 0.0 },
            absorption_g: alpha,
            distribution,
            ..Default::default()
        },
        Material::Principled {
            base_color,
            roughness,
            lobes,
            eta,
            thin,
        } => {
            let [anisotropic, spec_trans, metallic, clearcoat, clearcoat_gloss, sheen, sheen_tint, flatness, spec_tint, diff_trans] =
                lobes.textures().map(|t| t.unwrap_or(NO_TEXTURE));
            GpuMaterial {
                tag,
                texture: base_color,
                p0: eta,
                p1: if thin { 1.0 } else { 0.0 },
                pr_roughness: roughness,
                pr_anisotropic: anisotropic,
                pr_spec_trans: spec_trans,
                pr_metallic: metallic,
                pr_clearcoat: clearcoat,
                pr_clearcoat_gloss: clearcoat_gloss,
                pr_sheen: sheen,
                pr_sheen_tint: sheen_tint,
                pr_flatness: flatness,
                pr_spec_tint: spec_tint,
                pr_diff_trans: diff_trans,
                ..Default::default()
            }
        }
        Material::DiffuseLight { emission } => GpuMaterial {
            tag,
            texture: emission,
            ..Default::default()
        },
        Material::Ggx {
            base_color,
            metallic,
            roughness,
            metallic_roughness,
            normal_map,
            clearcoat,
        } => GpuMaterial {
            tag,
            texture: base_color,
            p0: metallic,
            p1: roughness,
            texture2: metallic_roughness.unwrap_or(NO_TEXTURE),
            texture3: normal_map.map_or(NO_TEXTURE, |n| n.texture),
            p2: normal_map.map_or(0.0, |n| n.scale),
            coat: clearcoat.map_or(0.0, |c| c.factor),
            coat_texture: clearcoat.and_then(|c| c.texture).unwrap_or(NO_TEXTURE),
            coat_roughness: clearcoat.map_or(0.0, |c| c.roughness),
            coat_roughness_texture: clearcoat
                .and_then(|c| c.roughness_texture)
                .unwrap_or(NO_TEXTURE),
            ..Default::default()
        },
    }
}

/// The images as the GPU stores them: the two byte-decoding tables first
/// (`TEXEL_TABLE_SRGB8`, `TEXEL_TABLE_UNORM8`), then each image, as packed
/// bytes where every channel of every texel is one of a table's values
/// (an 8-bit image decoded by the loaders: a third of the memory, and the
/// same floats once looked up), else as three floats a texel.
fn pack_images(images: &[reference::texture::ImageData]) -> (Vec<GpuImage>, Vec<f32>) {
    use reference::texture::decode_8bit;
    use std::collections::HashMap;
    let mut texels: Vec<f32> = [true, false]
        .iter()
        .flat_map(|&srgb| (0..=255).map(move |c| decode_8bit(c, srgb)))
        .collect();
    debug_assert_eq!(texels.len() as u32, TEXEL_TABLE_UNORM8 + 256);
    // Bits of a table's values → the byte (a value in both tables, such
    // as 0 or 1, decodes the same through either).
    let index = |srgb: bool| -> HashMap<u32, u32> {
        (0..=255u8)
            .map(|c| (decode_8bit(c, srgb).to_bits(), c as u32))
            .collect()
    };
    let tables = [(IMAGE_SRGB8, index(true)), (IMAGE_UNORM8, index(false))];
    let mut packed = Vec::with_capacity(images.len());
    for img in images {
        let offset = texels.len() as u32;
        let table = tables.iter().find(|(_, bytes)| {
            img.texels.iter().all(|t| {
                t.to_array()
                    .iter()
                    .all(|c| bytes.contains_key(&c.to_bits()))
            })
        });
        let format = match table {
            Some((format, bytes)) => {
                texels.extend(img.texels.iter().map(|t| {
                    let [r, g, b] = t.to_array().map(|c| bytes[&c.to_bits()]);
                    (r | g << PACKED_CHANNEL_BITS | b << (2 * PACKED_CHANNEL_BITS)) as f32
                }));
                *format
            }
            None => {
                texels.extend(img.texels.iter().flat_map(|t| t.to_array()));
                IMAGE_F32
            }
        };
        packed.push(GpuImage {
            offset,
            width: img.width,
            height: img.height,
            format,
        });
    }
    (packed, texels)
}

/// The vertices' optional attributes, one record a vertex where the scene
/// has any (each array of `mesh` is empty or one entry a vertex), else
/// none.
fn vertex_extras(mesh: &reference::shapes::MeshData) -> Vec<GpuVertexExtra> {
    if mesh.colors.is_empty() && mesh.tangents.is_empty() && mesh.uvs1.is_empty() {
        return Vec::new();
    }
    (0..mesh.positions.len())
        .map(|i| {
            let c = mesh.colors.get(i).copied().unwrap_or(glam::Vec4::ONE);
            let t = mesh.tangents.get(i).copied().unwrap_or(glam::Vec4::ZERO);
            let uv = mesh.uvs1.get(i).copied().unwrap_or(glam::Vec2::ZERO);
            GpuVertexExtra {
                r: c.x,
                g: c.y,
                b: c.z,
                a: c.w,
                t_x: t.x,
                t_y: t.y,
                t_z: t.z,
                t_w: t.w,
                u1: uv.x,
                v1: uv.y,
                ..Default::default()
            }
        })
        .collect()
}

pub fn pack_texture(t: &Texture) -> GpuTexture {
    let tag = t.tag();
    match *t {
        Texture::Constant(c) => GpuTexture {
            tag,
            r: c.x,
            g: c.y,
            b: c.z,
            ..Default::default()
        },
        Texture::Checker { scale, even, odd } => GpuTexture {
            tag,
            even,
            odd,
            scale,
            ..Default::default()
        },
        Texture::Image {
            image,
            factor,
            sampler,
        } => with_sampler(
            GpuTexture {
                tag,
                image,
                r: factor.x,
                g: factor.y,
                b: factor.z,
                ..Default::default()
            },
            &sampler,
        ),
        Texture::UvChecker { sampler, even, odd } => with_sampler(
            GpuTexture {
                tag,
                even,
                odd,
                ..Default::default()
            },
            &sampler,
        ),
        Texture::VertexColor { factor } => GpuTexture {
            tag,
            r: factor.x,
            g: factor.y,
            b: factor.z,
            ..Default::default()
        },
    }
}

/// `t` with a sampler's `GpuTexture::sampler` bits and its transform (the
/// identity where it has none).
fn with_sampler(t: GpuTexture, sampler: &Sampler) -> GpuTexture {
    let mut bits = sampler.wrap_u.tag() | sampler.wrap_v.tag() << SAMPLER_WRAP_V_SHIFT;
    if sampler.nearest {
        bits |= SAMPLER_NEAREST;
    }
    if sampler.tex_coord == 1 {
        bits |= SAMPLER_UV1;
    }
    if sampler.transform.is_some() {
        bits |= SAMPLER_TRANSFORM;
    }
    let [t0, t1, t2, t3, t4, t5] = sampler.transform.unwrap_or([1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    GpuTexture {
        sampler: bits,
        t0,
        t1,
        t2,
        t3,
        t4,
        t5,
        ..t
    }
}

impl PackedScene {
    /// Each array with the binding it is uploaded to (every one of
    /// [`bindings::SCENE_ARRAYS`], in slot order).
    pub fn arrays(&self) -> [(Binding, std::borrow::Cow<'_, [u8]>); 15] {
        use bytemuck::cast_slice;
        use std::borrow::Cow;
        fn bytes<T: bytemuck::Pod>(v: &[T]) -> Cow<'_, [u8]> {
            Cow::Borrowed(cast_slice(v))
        }
        // The array-of-structures words are the records' own bytes.
        let nodes = match (self.traversal, self.node_layout) {
            (Traversal::Compressed, layout) => {
                let root = self
                    .nodes
                    .first()
                    .copied()
                    .unwrap_or(bytemuck::Zeroable::zeroed());
                Cow::Owned(
                    cast_slice(&crate::traversal::compressed_words(
                        &root,
                        &self.compressed,
                        layout,
                    ))
                    .to_vec(),
                )
            }
            (_, NodeLayout::Aos) => bytes(&self.nodes),
            (_, NodeLayout::Soa) => Cow::Owned(
                cast_slice(&crate::traversal::node_words(&self.nodes, self.node_layout)).to_vec(),
            ),
        };
        [
            (bindings::NODES, nodes),
            (bindings::LEAF_ENTRIES, bytes(&self.leaf_entries)),
            (bindings::PRIMITIVES, bytes(&self.primitives)),
            (bindings::SPHERES, bytes(&self.spheres)),
            (bindings::QUADS, bytes(&self.quads)),
            (bindings::TRIANGLES, bytes(&self.triangles)),
            (bindings::VERTICES, bytes(&self.vertices)),
            (bindings::MATERIALS, bytes(&self.materials)),
            (bindings::TEXTURES, bytes(&self.textures)),
            (bindings::IMAGES, bytes(&self.images)),
            (bindings::TEXELS, bytes(&self.texels)),
            (bindings::EMITTERS, bytes(&self.emitters)),
            (bindings::LIGHT_DENSITIES, bytes(&self.light_densities)),
            (bindings::VERTEX_EXTRAS, bytes(&self.vertex_extras)),
            (bindings::QUADRICS, bytes(&self.quadrics)),
        ]
    }

    /// The scene's records for the binary walk over indexed leaves (the
    /// baseline).
    pub fn new(scene: &Scene) -> Self {
        Self::for_walk(scene, Traversal::Binary, LeafLayout::Indexed)
    }

    /// The scene's records for `traversal` with `leaves`, or for the binary
    /// walk or indexed leaves where the others are refused
    /// ([`Self::traversal_note`] says why).
    pub fn for_walk(scene: &Scene, traversal: Traversal, leaves: LeafLayout) -> Self {
        let (walk, refused) = crate::traversal::arrays(scene, traversal);
        let crate::traversal::WalkArrays {
            nodes,
            compressed,
            order,
        } = walk;
        let (traversal, traversal_note) = match refused {
            Ok(()) => (traversal, None),
            Err(why) => (
                Traversal::Binary,
                Some(format!("{why}: the binary walk is used")),
            ),
        };
        let (images, texels) = pack_images(scene.images());
        let mut texels = texels;
        let m = &scene.mesh();
        let lights = LightSet::new(scene);
        let punctual = LightSet::punctual_only(scene);
        let (mut env_pmf, mut env_table) = (0.0, 0);
        if let Some((env, pmf)) = lights.env() {
            env_pmf = pmf;
            env_table = texels.len() as u32;
            texels.extend_from_slice(&env.row_cdf);
            texels.extend_from_slice(&env.col_cdf);
            texels.extend_from_slice(&env.cell_pdf);
        }
        let punctual_table = texels.len() as u32;
        for (i, l) in scene.punctual_lights().iter().enumerate() {
            let record = GpuPunctualLight {
                tag: l.tag as f32,
                position_x: l.position.x,
                position_y: l.position.y,
                position_z: l.position.z,
                direction_x: l.direction.x,
                direction_y: l.direction.y,
                direction_z: l.direction.z,
                intensity_r: l.intensity.x,
                intensity_g: l.intensity.y,
                intensity_b: l.intensity.z,
                cos_outer: l.cos_outer,
                angle_scale: l.angle_scale(),
                pmf_mis: lights.punctual_pmf(i as u32),
                pmf_bsdf: punctual.punctual_pmf(i as u32),
                cos_inner: l.cos_inner,
                texture: light_texture(l.texture),
                axis_x_x: l.axis_x.x,
                axis_x_y: l.axis_x.y,
                axis_x_z: l.axis_x.z,
                axis_y_x: l.axis_y.x,
                axis_y_y: l.axis_y.y,
                axis_y_z: l.axis_y.z,
                profile_0: l.profile[0],
                profile_1: l.profile[1],
                profile_2: l.profile[2],
                ..Default::default()
            };
            texels.extend_from_slice(bytemuck::cast_slice(&[record]));
        }
        // The signed distance grids: each grid's maps a record after the
        // quadrics', its samples in `texels`; each cell a record of four
        // floats in `texels` (its grid's record, its x, y, z: exact
        // integers), which its primitive's index points at.
        let mut quadrics: Vec<GpuQuadric> = scene.quadrics().iter().map(pack_quadric).collect();
        let mut sdf_cells = Vec::with_capacity(scene.sdf_voxels().len());
        for (g, grid) in scene.sdf_grids().iter().enumerate() {
            let samples = texels.len() as u32;
            texels.extend_from_slice(&grid.values);
            quadrics.push(GpuQuadric {
                nx: grid.dims[0],
                ny: grid.dims[1],
                nz: grid.dims[2],
                samples,
                smooth_normals: u32::from(grid.smooth),
                ..pack_quadric(&grid.map)
            });
            debug_assert_eq!(quadrics.len(), scene.quadrics().len() + g + 1);
        }
        for v in scene.sdf_voxels() {
            sdf_cells.push(texels.len() as u32);
            let record = (scene.quadrics().len() as u32 + v.grid) as f32;
            texels.extend([record, v.cell[0] as f32, v.cell[1] as f32, v.cell[2] as f32]);
        }
        // The instanced groups: each one's tree in `texels` (its binary
        // nodes, then its leaves' entries: group-relative triangle
        // indices), each instance's maps a record after the grids', which
        // its primitive's index names.
        let group_trees: Vec<(u32, u32)> = scene
            .groups()
            .iter()
            .map(|g| {
                let nodes = texels.len() as u32;
                texels.extend(g.bvh().nodes().iter().flat_map(instance_node));
                let entries = texels.len() as u32;
                texels.extend(g.bvh().prim_order().iter().map(|&i| i as f32));
                (nodes, entries)
            })
            .collect();
        let first_instance = quadrics.len() as u32;
        for inst in scene.instances() {
            let g = &scene.groups()[inst.group as usize];
            let (nodes, entries) = group_trees[inst.group as usize];
            quadrics.push(GpuQuadric {
                nx: nodes,
                ny: g.triangles().start,
                nz: entries,
                ..pack_quadric(&inst.map)
            });
        }
        let filter_table = match scene.filter_table() {
            None => NO_FILTER_TABLE,
            Some(t) => {
                let at = texels.len() as u32;
                texels.extend(t.to_words());
                at
            }
        };
        let mut packed = PackedScene {
            traversal,
            leaves: LeafLayout::Indexed,
            traversal_note,
            nodes,
            compressed,
            node_layout: NodeLayout::Aos,
            leaf_entries: crate::traversal::indexed_entries(&order),
            primitives: scene
                .primitives()
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let b = scene.primitive_bounds(i as u32);
                    GpuPrimitive {
                        tag: p.tag,
                        // A grid cell's record in `texels`, an instance's
                        // among the quadrics'.
                        index: match p.tag {
                            reference::scene::primitive_tag::SDF_VOXEL => {
                                sdf_cells[p.index as usize]
                            }
                            reference::scene::primitive_tag::INSTANCE => first_instance + p.index,
                            _ => p.index,
                        },
                        lo_x: b.min.x,
                        lo_y: b.min.y,
                        lo_z: b.min.z,
                        hi_x: b.max.x,
                        hi_y: b.max.y,
                        hi_z: b.max.z,
                    }
                })
                .collect(),
            spheres: scene
                .spheres()
                .iter()
                .map(|s| GpuSphere {
                    center_x: s.center.x,
                    center_y: s.center.y,
                    center_z: s.center.z,
                    radius: s.radius,
                    material: s.material,
                    ..Default::default()
                })
                .collect(),
            quads: scene
                .quads()
                .iter()
                .map(|q| GpuQuad {
                    corner_x: q.corner.x,
                    corner_y: q.corner.y,
                    corner_z: q.corner.z,
                    material: q.material,
                    u_x: q.u.x,
                    u_y: q.u.y,
                    u_z: q.u.z,
                    v_x: q.v.x,
                    v_y: q.v.y,
                    v_z: q.v.z,
                    ..Default::default()
                })
                .collect(),
            quadrics,
            triangles: scene
                .triangles()
                .iter()
                .map(|t| GpuTriangle {
                    v0: t.vertices[0],
                    v1: t.vertices[1],
                    v2: t.vertices[2],
                    material: t.material,
                    flags: t.flags,
                    ..Default::default()
                })
                .collect(),
            vertices: (0..m.positions.len())
                .map(|i| {
                    let (p, n, uv) = (m.positions[i], m.normals[i], m.uvs[i]);
                    GpuVertex {
                        p_x: p.x,
                        p_y: p.y,
                        p_z: p.z,
                        n_x: n.x,
                        n_y: n.y,
                        n_z: n.z,
                        u: uv.x,
                        v: uv.y,
                    }
                })
                .collect(),
            vertex_extras: vertex_extras(m),
            materials: assign_shade_buckets(
                (scene.materials().iter().enumerate())
                    .map(|(i, m)| {
                        let i = i as u32;
                        let record = pack_material(m, scene.alpha(i), scene.emission(i));
                        pack_wrappers(record, scene.wrappers(i))
                    })
                    .collect(),
            ),
            textures: scene.textures().iter().map(pack_texture).collect(),
            images,
            texels,
            emitter_count: lights.len() as u32,
            punctual_table,
            filter_table,
            punctual_count: punctual.len() as u32,
            emitters: (lights.emitters().chain(punctual.emitters()))
                .map(|(prim, cdf)| GpuEmitter { prim, cdf })
                .collect(),
            light_densities: (0..scene.primitives().len() as u32)
                .map(|prim| GpuLightDensity {
                    pmf: lights.pmf(prim),
                    area: lights.area(prim),
                })
                .collect(),
            env_pmf,
            env_table,
        };
        if leaves != LeafLayout::Indexed {
            match inline_entries(&order, &packed) {
                Ok(entries) => {
                    packed.leaves = leaves;
                    packed.leaf_entries = match leaves {
                        LeafLayout::InlineSoa => crate::traversal::soa_entries(&entries),
                        _ => entries,
                    };
                }
                Err(why) => {
                    let note = format!("{why}: indexed leaves are used");
                    packed.traversal_note = Some(match packed.traversal_note.take() {
                        Some(first) => format!("{first}; {note}"),
                        None => note,
                    });
                }
            }
        }
        packed
    }

    /// Whether the walk over the records ends whatever the rays
    /// ([`crate::traversal::check_walk_order`]): what trusted kernels
    /// need.
    pub fn check_walk_order(&self) -> Result<(), String> {
        crate::traversal::check_walk_order(&self.nodes, &self.compressed, self.traversal)
    }

    /// A bound on the records one ray's walk visits (loop iterations):
    /// every record of the node walks; the compressed walk's root, its
    /// nodes and its leaf children.
    pub fn walk_records(&self) -> u64 {
        let leaves = |n: &crate::compressed::CompressedNode| {
            (0..crate::compressed::WIDTH)
                .filter(|&s| n.leaf(s).is_some())
                .count() as u64
        };
        match self.traversal {
            Traversal::Compressed => {
                self.nodes.len() as u64 + self.compressed.iter().map(|n| 1 + leaves(n)).sum::<u64>()
            }
            _ => self.nodes.len() as u64,
        }
    }

    /// The same records, uploaded in `layout`.
    pub fn with_node_layout(self, layout: NodeLayout) -> Self {
        Self {
            node_layout: layout,
            ..self
        }
    }
}

/// The inline entries of `order` ([`LeafLayout::Inline`]), from the packed
/// records the indexed layout's test reads (so the same floats), or why
/// not (ids from [`INLINE_ALPHA`] up). Its words are laid out as
/// `crate::traversal` defines them ([`INLINE_WORDS`], [`INLINE_TAG_SHIFT`]).
pub fn inline_entries(order: &[u32], p: &PackedScene) -> Result<Vec<[u32; 4]>, String> {
    use reference::scene::primitive_tag;
    use reference::shapes::TRIANGLE_HAS_ALPHA;
    if p.primitives.len() as u64 > INLINE_ALPHA as u64 {
        return Err(format!(
            "inline leaf entries hold ids under 2^{}; this scene has {} primitives",
            INLINE_ALPHA.trailing_zeros(),
            p.primitives.len()
        ));
    }
    let mut out = Vec::with_capacity(order.len() * INLINE_WORDS);
    for &prim in order {
        let g = &p.primitives[prim as usize];
        let i = g.index as usize;
        let shape: [f32; 9] = match g.tag {
            primitive_tag::SPHERE => {
                let s = &p.spheres[i];
                [
                    s.center_x, s.center_y, s.center_z, s.radius, 0.0, 0.0, 0.0, 0.0, 0.0,
                ]
            }
            primitive_tag::QUAD => {
                let q = &p.quads[i];
                [
                    q.corner_x, q.corner_y, q.corner_z, q.u_x, q.u_y, q.u_z, q.v_x, q.v_y, q.v_z,
                ]
            }
            // The kernel reads the quadric's record (its maps do not fit
            // nine floats): the first float holds its index's bits.
            primitive_tag::QUADRIC | primitive_tag::SDF_VOXEL | primitive_tag::INSTANCE => [
                f32::from_bits(g.index),
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
            ],
            _ => {
                // Triangles, and any other tag: the kernel poisons an
                // unknown tag whatever the floats.
                let t = p.triangles.get(i);
                let v = |k: Option<u32>| {
                    k.and_then(|k| p.vertices.get(k as usize))
                        .map_or([0.0; 3], |v| [v.p_x, v.p_y, v.p_z])
                };
                let (a, b, c) = (v(t.map(|t| t.v0)), v(t.map(|t| t.v1)), v(t.map(|t| t.v2)));
                [a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]]
            }
        };
        let f = |x: f32| x.to_bits();
        let alpha = g.tag == primitive_tag::TRIANGLE
            && p.triangles
                .get(i)
                .is_some_and(|t| t.flags & TRIANGLE_HAS_ALPHA != 0);
        // An unknown tag stays unknown (7 is none): the kernel poisons it.
        let head = prim | (g.tag.min(7) << INLINE_TAG_SHIFT) | if alpha { INLINE_ALPHA } else { 0 };
        out.push([head, f(g.lo_x), f(g.lo_y), f(g.lo_z)]);
        out.push([f(g.hi_x), f(g.hi_y), f(g.hi_z), f(shape[0])]);
        out.push([f(shape[1]), f(shape[2]), f(shape[3]), f(shape[4])]);
        out.push([f(shape[5]), f(shape[6]), f(shape[7]), f(shape[8])]);
    }
    Ok(out)
}

/// The floats of an instanced group's node in `texels`: its box's
/// minimum, its index, its box's maximum, its meta bits (the index and
/// the meta bits as exact integers: `reference`'s groups are small
/// enough, `reference::scene::MAX_GROUP_TRIANGLES`).
pub const INSTANCE_NODE_FLOATS: u32 = 8;

fn instance_node(n: &reference::bvh::BvhNode) -> [f32; INSTANCE_NODE_FLOATS as usize] {
    [
        n.min[0],
        n.min[1],
        n.min[2],
        n.index as f32,
        n.max[0],
        n.max[1],
        n.max[2],
        n.meta as f32,
    ]
}

/// A quadric's record.
fn pack_quadric(q: &reference::shapes::Quadric) -> GpuQuadric {
    let [l0, l1, l2] = q.linear;
    let [i0, i1, i2] = q.inv_linear;
    let (o, io) = (q.origin, q.inv_origin);
    GpuQuadric {
        l0_x: l0.x,
        l0_y: l0.y,
        l0_z: l0.z,
        kind: q.kind,
        l1_x: l1.x,
        l1_y: l1.y,
        l1_z: l1.z,
        material: q.material,
        l2_x: l2.x,
        l2_y: l2.y,
        l2_z: l2.z,
        flip: u32::from(q.flip),
        o_x: o.x,
        o_y: o.y,
        o_z: o.z,
        i0_x: i0.x,
        i0_y: i0.y,
        i0_z: i0.z,
        i1_x: i1.x,
        i1_y: i1.y,
        i1_z: i1.z,
        i2_x: i2.x,
        i2_y: i2.y,
        i2_z: i2.z,
        io_x: io.x,
        io_y: io.y,
        io_z: io.z,
        ..Default::default()
    }
}

/// The background's part of the per-dispatch parameters.
pub fn pack_background(bg: &Background, p: &mut GpuParams) {
    p.bg_tag = bg.tag();
    match *bg {
        Background::Solid(c) => [p.bg_a_r, p.bg_a_g, p.bg_a_b] = c.to_array(),
        Background::Sky { horizon, zenith } => {
            [p.bg_a_r, p.bg_a_g, p.bg_a_b] = horizon.to_array();
            [p.bg_b_r, p.bg_b_g, p.bg_b_b] = zenith.to_array();
        }
        Background::Envmap {
            image,
            intensity,
            to_map,
            rows,
        } => {
            p.bg_image = image;
            p.bg_intensity = intensity;
            // The reference's own matrix, by rows.
            let r = to_map.transpose().to_cols_array();
            [p.bg_map_xx, p.bg_map_xy, p.bg_map_xz] = [r[0], r[1], r[2]];
            [p.bg_map_yx, p.bg_map_yy, p.bg_map_yz] = [r[3], r[4], r[5]];
            [p.bg_map_zx, p.bg_map_zy, p.bg_map_zz] = [r[6], r[7], r[8]];
            p.bg_rows = rows.tag();
        }
    }
}

/// A punctual light's texture id as [`GpuPunctualLight::texture`] holds
/// it: an exact float, −1 for none. Ids stay below 2^24 (a scene of more
/// textures would not fit the GPU's texture table long before).
fn light_texture(id: u32) -> f32 {
    if id == reference::light::NO_TEXTURE {
        return -1.0;
    }
    assert!(id < 1 << 24, "texture id {id} is not exact in f32");
    id as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use reference::texture::{decode_8bit, ImageData};

    /// The WGSL `texel`, in Rust: what the GPU reads for texel `k`.
    fn texel(texels: &[f32], img: &GpuImage, k: u32) -> Vec3 {
        if img.format == IMAGE_F32 {
            let i = (img.offset + 3 * k) as usize;
            return Vec3::new(texels[i], texels[i + 1], texels[i + 2]);
        }
        let word = texels[(img.offset + k) as usize] as u32;
        let table = match img.format {
            IMAGE_UNORM8 => TEXEL_TABLE_UNORM8,
            _ => TEXEL_TABLE_SRGB8,
        };
        let channel = |c: u32| texels[(table + c) as usize];
        Vec3::new(
            channel(word & PACKED_CHANNEL_MASK),
            channel((word >> PACKED_CHANNEL_BITS) & PACKED_CHANNEL_MASK),
            channel(word >> (2 * PACKED_CHANNEL_BITS)),
        )
    }

    fn image(texels: Vec<Vec3>) -> ImageData {
        ImageData {
            width: texels.len() as u32,
            height: 1,
            texels,
        }
    }

    /// Buckets hold one kind of material each where there are buckets
    /// enough, follow the kinds' order, and never reach the last bucket
    /// (the misses').
    #[test]
    fn shade_buckets_group_materials_by_kind_then_index() {
        let with_tag = |tags: &[u32]| -> Vec<u32> {
            let materials = tags
                .iter()
                .map(|&tag| GpuMaterial {
                    tag,
                    ..Default::default()
                })
                .collect();
            assign_shade_buckets(materials)
                .iter()
                .map(|m| m.shade_bucket)
                .collect()
        };
        // Three materials: ranks by tag (index 1 first, then 2, then 0).
        let b = with_tag(&[2, 0, 1]);
        assert!(b[1] < b[2] && b[2] < b[0], "{b:?}");
        // 480 materials of three kinds (rtow-final's spheres): sorted by
        // kind, buckets never decrease, and each of the 63 is used.
        let tags: Vec<u32> = (0..480).map(|i| (i * 7 % 3) as u32).collect();
        let b = with_tag(&tags);
        let last = crate::records::SORT_BUCKETS - 1;
        assert!(b.iter().all(|&x| x < last));
        let mut by_rank: Vec<(u32, usize)> = (0..480).map(|i| (tags[i], i)).collect();
        by_rank.sort();
        let in_rank: Vec<u32> = by_rank.iter().map(|&(_, i)| b[i]).collect();
        assert!(in_rank.windows(2).all(|w| w[0] <= w[1]));
        let mut used = in_rank.clone();
        used.dedup();
        assert_eq!(used.len(), last as usize);
        // No materials: nothing to do.
        assert!(with_tag(&[]).is_empty());
    }

    /// The scene-file image loader decodes 8-bit images to the same
    /// floats as `decode_8bit`, so they pack; an HDR image does not.
    #[test]
    fn a_scene_files_png_is_packed_and_its_hdr_is_not() {
        let formats = |scene: &str| -> Vec<u32> {
            let path = format!("{}/../fixtures/scenes/{scene}", env!("CARGO_MANIFEST_DIR"));
            let scene = reference::load_scene(&path).unwrap();
            pack_images(scene.images())
                .0
                .iter()
                .map(|p| p.format)
                .collect()
        };
        assert_eq!(formats("textures.json"), [IMAGE_SRGB8]); // uv_grid.png
        assert_eq!(formats("skybox.json"), [IMAGE_F32]); // sky.hdr
    }

    #[test]
    fn eight_bit_images_pack_to_a_float_a_texel_and_read_back_bit_for_bit() {
        let bytes = |srgb: bool| -> Vec<Vec3> {
            (0..=255u8)
                .map(|c| {
                    Vec3::new(
                        decode_8bit(c, srgb),
                        decode_8bit(255 - c, srgb),
                        decode_8bit(c / 3, srgb),
                    )
                })
                .collect()
        };
        let hdr = vec![Vec3::new(0.1, 2.5, 1e-3), Vec3::splat(0.3)];
        let grey = vec![Vec3::ZERO, Vec3::ONE];
        let images = [
            image(bytes(true)),
            image(bytes(false)),
            image(hdr),
            image(grey),
        ];
        let (packed, texels) = pack_images(&images);
        let formats: Vec<u32> = packed.iter().map(|p| p.format).collect();
        assert_eq!(formats, [IMAGE_SRGB8, IMAGE_UNORM8, IMAGE_F32, IMAGE_SRGB8]);
        // Tables (512), then 256 + 256 packed texels, 2 x 3 floats, 2.
        assert_eq!(texels.len(), 512 + 256 + 256 + 6 + 2);
        for (img, gpu) in images.iter().zip(&packed) {
            for (k, t) in img.texels.iter().enumerate() {
                let read = texel(&texels, gpu, k as u32);
                assert_eq!(
                    read.to_array().map(f32::to_bits),
                    t.to_array().map(f32::to_bits),
                    "texel {k}"
                );
            }
        }
    }
}
