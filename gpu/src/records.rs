//! GPU records: one `#[repr(C)]` `Pod` struct per record, defined once
//! here. The [`gpu_record!`] macro emits the Rust struct and its WGSL
//! mirror from the same field list, so the two cannot drift; a layout test
//! (tests/gpu/gpu_buffer_layout.rs) still checks what the shader reads. Fields are
//! scalar `f32`/`u32` only: no `vec3` in storage structs, so WGSL's layout
//! equals C's (align 4, stride = size).

macro_rules! gpu_record {
    ($(#[$m:meta])* $name:ident { $($(#[$fm:meta])* $field:ident : $ty:ident),* $(,)? }) => {
        $(#[$m])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
        pub struct $name {
            $($(#[$fm])* pub $field: $ty),*
        }

        impl $name {
            /// The WGSL declaration of this record.
            pub const WGSL: &'static str = concat!("struct ", stringify!($name), " {\n", $("    ", stringify!($field), ": ", stringify!($ty), ",\n",)* "}\n");
            /// Field names in declaration order (for the layout test).
            pub const FIELDS: &'static [&'static str] = &[$(stringify!($field)),*];
        }
    };
}

gpu_record! {
    /// A sphere (`reference::shapes::Sphere`).
    GpuSphere { center_x: f32, center_y: f32, center_z: f32, radius: f32, material: u32, _pad0: u32, _pad1: u32, _pad2: u32 }
}

gpu_record! {
    /// A parallelogram (`reference::shapes::Quad`).
    GpuQuad {
        corner_x: f32, corner_y: f32, corner_z: f32, material: u32,
        u_x: f32, u_y: f32, u_z: f32, _pad0: u32,
        v_x: f32, v_y: f32, v_z: f32, _pad1: u32,
    }
}

gpu_record! {
    /// A disk, cylinder or textured sphere in its own object space
    /// (`reference::shapes::Quadric`): object → world by columns `l0`,
    /// `l1`, `l2` and origin `o`; world → object by columns `i0`, `i1`,
    /// `i2` and origin `io`; `flip` 1 for an inward normal. A record of
    /// kind `QUADRIC_SDF` holds a signed distance grid's maps
    /// (`reference::sdf::SdfGrid`): `nx`, `ny`, `nz` its samples per
    /// axis, `samples` where they start in `texels`, `smooth_normals` 1 for smooth
    /// shading normals (all 0 in a quadric's). A record of kind
    /// `QUADRIC_INSTANCE` holds an instance's maps
    /// (`reference::shapes::Instance`): `nx` where its group's nodes
    /// start in `texels`, `ny` the group's first triangle, `nz` where its
    /// leaves' entries start in `texels`.
    GpuQuadric {
        l0_x: f32, l0_y: f32, l0_z: f32, kind: u32,
        l1_x: f32, l1_y: f32, l1_z: f32, material: u32,
        l2_x: f32, l2_y: f32, l2_z: f32, flip: u32,
        o_x: f32, o_y: f32, o_z: f32, nx: u32,
        i0_x: f32, i0_y: f32, i0_z: f32, ny: u32,
        i1_x: f32, i1_y: f32, i1_z: f32, nz: u32,
        i2_x: f32, i2_y: f32, i2_z: f32, samples: u32,
        io_x: f32, io_y: f32, io_z: f32, smooth_normals: u32,
    }
}

gpu_record! {
    /// A triangle of the shared vertex array (`reference::shapes::Triangle`).
    GpuTriangle { v0: u32, v1: u32, v2: u32, material: u32, flags: u32, _pad0: u32, _pad1: u32, _pad2: u32 }
}

gpu_record! {
    /// One vertex: world position, shading normal (zero if absent), uv.
    GpuVertex { p_x: f32, p_y: f32, p_z: f32, n_x: f32, n_y: f32, n_z: f32, u: f32, v: f32 }
}

gpu_record! {
    /// A vertex's optional attributes (`reference::shapes::MeshData`'s
    /// `colors`, `tangents` and `uvs1`), read where the triangle's flags
    /// say it has them: linear RGBA colour, tangent (`w`: the bitangent's
    /// side), the second uv set.
    GpuVertexExtra {
        r: f32, g: f32, b: f32, a: f32,
        t_x: f32, t_y: f32, t_z: f32, t_w: f32,
        u1: f32, v1: f32, _pad0: u32, _pad1: u32,
    }
}

gpu_record! {
    /// An entry of the primitive list (`reference::scene::Primitive`).
    GpuPrimitive {
        tag: u32, index: u32,
        // The box the BVH build computed (reference::Scene::primitive_bounds),
        // for the admits rule.
        lo_x: f32, lo_y: f32, lo_z: f32, hi_x: f32, hi_y: f32, hi_z: f32,
    }
}

/// `GpuMaterial::texture2` of a material without a second texture.
pub const NO_TEXTURE: u32 = u32::MAX;

/// `GpuMaterial::alpha_cutoff` of BLEND (stochastic transparency): below
/// every MASK cutoff, which are stored at least 0.
pub const ALPHA_BLEND: f32 = -1.0;

gpu_record! {
    /// A material (`reference::material::Material`), by tag:
    /// LAMBERTIAN `texture` = albedo; METAL `texture` = albedo, `p0` = fuzz;
    /// DIELECTRIC `p0` = ior, `absorption_*`; DIFFUSE_LIGHT `texture` =
    /// emission; CONDUCTOR `texture` = the specular tint, `p0..p2` = eta,
    /// `absorption_*` = k; ROUGH_CONDUCTOR as CONDUCTOR, with `texture2` =
    /// the roughness and `distribution` its microfacets'
    /// (`reference::microfacet::distribution`); SMOOTH_DIELECTRIC and
    /// THIN_DIELECTRIC `p0` = eta, `texture` = the reflectance, `texture2`
    /// = the transmittance; ROUGH_DIELECTRIC `p0` = eta, `texture` = the
    /// reflectance, `texture2` = the roughness, `texture3` = the
    /// transmittance, `distribution`; PLASTIC `texture` = the diffuse
    /// reflectance, `texture3` = the specular tint, `p0` = eta, `p1` = the
    /// coat's inner diffuse reflectance
    /// (`reference::material::plastic_internal_reflectance`), `p2` = the
    /// specular sampling weight, `absorption_r` = 1 where nonlinear, else
    /// 0; ROUGH_PLASTIC as PLASTIC, with `p1` = its coat's own inner
    /// reflectance, `texture2` = the image of its coat's transmittance
    /// table, `absorption_g` = alpha, `distribution`; GGX `texture` = base colour, `p0` = metallic, `p1` =
    /// roughness, `texture2` = the metallic-roughness texture or
    /// `NO_TEXTURE`, `texture3` = the normal map or `NO_TEXTURE`, `p2` =
    /// the normal map's scale. Any tag: `alpha_texture` = the coverage's
    /// texture (`reference::material::Alpha`) or `NO_TEXTURE`,
    /// `alpha_cutoff` = MASK's cutoff (at least 0: alpha is never
    /// negative, so a lower cutoff covers alike) or [`ALPHA_BLEND`].
    /// GGX's clear coat (`reference::material::ClearCoat`): `coat` = its
    /// weight (0: none), `coat_texture` its texture or `NO_TEXTURE`,
    /// `coat_roughness`, `coat_roughness_texture`. Any tag: `emission` =
    /// the texture of what it emits from its front face
    /// (`reference::Scene::emission`: DIFFUSE_LIGHT's own, which is also
    /// its `texture`, or the emission added to another BSDF) or
    /// `NO_TEXTURE`. Any tag: `shade_bucket` = where the sorted
    /// wavefront shades the paths that hit it
    /// (`scene_buffers::assign_shade_buckets`). Any tag, Mitsuba's
    /// wrappers (`reference::material::Wrappers`): `opacity` = the mask's
    /// texture or `NO_TEXTURE`, `one_sided` = 1 where the material absorbs
    /// behind, else 0, `normal_map` = Mitsuba's normal map's texture or
    /// `NO_TEXTURE` (a bump map's height where `normal_map_mode` has
    /// [`NORMAL_MAP_BUMP`]), `normal_map_mode` = [`NORMAL_MAP_MIRRORED`]
    /// where it is read in the frame turned to the viewer, and
    /// [`NORMAL_MAP_BUMP`] where it is Mitsuba's bump map. ROUGH_CONDUCTOR and ROUGH_DIELECTRIC:
    /// `alpha_v` = the roughness across the tangent where anisotropic,
    /// else `NO_TEXTURE`. Any tag, Mitsuba's `blendbsdf`
    /// (`reference::material::Blend`): `blend_second` = the second BSDF's
    /// material or `NO_TEXTURE` (no blend), `blend_weight` = the weight's
    /// texture. PRINCIPLED (`reference::material::Material::Principled`):
    /// `texture` = the base colour, `p0` = eta, `p1` = 1 for the thin
    /// sheet (`principledthin`), else 0, `pr_*` its one-channel
    /// parameters' textures or `NO_TEXTURE` (not given: 0).
    GpuMaterial {
        tag: u32, texture: u32, p0: f32, p1: f32,
        absorption_r: f32, absorption_g: f32, absorption_b: f32, texture2: u32,
        texture3: u32, p2: f32, alpha_texture: u32, alpha_cutoff: f32,
        coat: f32, coat_texture: u32, coat_roughness: f32, coat_roughness_texture: u32,
        emission: u32, shade_bucket: u32, distribution: u32, opacity: u32,
        one_sided: u32, alpha_v: u32, normal_map: u32, normal_map_mode: u32,
        blend_weight: u32, blend_second: u32,
        pr_roughness: u32, pr_anisotropic: u32, pr_spec_trans: u32, pr_metallic: u32,
        pr_clearcoat: u32, pr_clearcoat_gloss: u32, pr_sheen: u32, pr_sheen_tint: u32,
        pr_flatness: u32, pr_spec_tint: u32, pr_diff_trans: u32,
    }
}

/// Buckets of the sorted wavefront's counting sort
/// (`crate::wavefront::ShadeOrder::Material`): `GpuMaterial::shade_bucket`
/// is one of the first `SORT_BUCKETS - 1` (`scene_buffers::assign_shade_buckets`);
/// the last holds misses and shadow-only paths.
pub const SORT_BUCKETS: u32 = 64;

/// `GpuMaterial::normal_map_mode` bits: the map is read in the frame
/// turned to the viewer (`reference::material::Wrappers::normal_map_mirrored`);
/// the map is a bump map's height (`Wrappers::bump_map`).
pub const NORMAL_MAP_MIRRORED: u32 = 1;
pub const NORMAL_MAP_BUMP: u32 = 1 << 1;

/// `GpuParams::filter_table` of the box filter (no table).
pub const NO_FILTER_TABLE: u32 = u32::MAX;

/// `GpuTexture::sampler` bits: the u axis's wrap tag
/// (`reference::texture::wrap_tag`) in bits 0-1, the v axis's in 2-3, then
/// the nearest filter, whether `t0..t5` transform uv, and the
/// coordinate set.
pub const SAMPLER_WRAP_V_SHIFT: u32 = 2;
pub const SAMPLER_WRAP_MASK: u32 = 3;
pub const SAMPLER_NEAREST: u32 = 1 << 4;
pub const SAMPLER_TRANSFORM: u32 = 1 << 5;
/// The texture reads the second set of texture coordinates.
pub const SAMPLER_UV1: u32 = 1 << 6;

gpu_record! {
    /// A texture (`reference::texture::Texture`), by tag: CONSTANT colour
    /// in `r, g, b`; CHECKER `scale`, `even`, `odd`; IMAGE `image` with the
    /// factor in `r, g, b`, its sampler's bits in `sampler` and its uv
    /// transform in `t0..t5`; VERTEX_COLOR the factor in `r, g, b`.
    GpuTexture { tag: u32, even: u32, odd: u32, image: u32, r: f32, g: f32, b: f32, scale: f32, sampler: u32, t0: f32, t1: f32, t2: f32, t3: f32, t4: f32, t5: f32, _pad0: u32 }
}

gpu_record! {
    /// An image's place in the shared texel array and how its texels are
    /// stored there (`format`: `IMAGE_F32`, three floats a texel; or
    /// `IMAGE_SRGB8` / `IMAGE_UNORM8`, one float a texel holding the
    /// integer `r + 256·g + 65536·b` of its bytes, decoded through the
    /// table at `TEXEL_TABLE_SRGB8` / `TEXEL_TABLE_UNORM8`).
    GpuImage { offset: u32, width: u32, height: u32, format: u32 }
}

/// `GpuImage::format`: three f32 a texel.
pub const IMAGE_F32: u32 = 0;
/// `GpuImage::format`: packed bytes of sRGB-encoded colour.
pub const IMAGE_SRGB8: u32 = 1;
/// `GpuImage::format`: packed bytes of data (`c / 255`).
pub const IMAGE_UNORM8: u32 = 2;
/// Where the texel array holds the 256 linear values of sRGB-encoded
/// bytes (`reference::texture::decode_8bit`), and after them those of data
/// bytes.
pub const TEXEL_TABLE_SRGB8: u32 = 0;
pub const TEXEL_TABLE_UNORM8: u32 = 256;
/// Bits of a channel in a packed texel (an integer below 2^24, exact in
/// an f32).
pub const PACKED_CHANNEL_BITS: u32 = 8;
pub const PACKED_CHANNEL_MASK: u32 = 255;

gpu_record! {
    /// An emitter of the light set (`reference::light::LightSet::emitters`):
    /// its primitive id and the cumulative selection probability up to and
    /// including it, searched by `light_set_sample`.
    GpuEmitter { prim: u32, cdf: f32 }
}

gpu_record! {
    /// A primitive's light-sampling density terms, by primitive id
    /// (`LightSet::pmf` and `LightSet::area`; both 0 for non-emitters).
    GpuLightDensity { pmf: f32, area: f32 }
}

gpu_record! {
    /// A punctual light (`reference::light::PunctualLight`), in `texels`
    /// from `GpuParams::punctual_table`, [`PUNCTUAL_LIGHT_WORDS`] floats
    /// each (`punctual_light_at` reads one): its tag as a float (0 to 4:
    /// exact), position, direction, intensity, the spot's `cos θ_o` and
    /// `PunctualLight::angle_scale`, its selection probability in the
    /// MIS estimator's light set and in the BSDF estimator's
    /// (`LightSet::punctual_pmf` of `LightSet::new` and of
    /// `LightSet::punctual_only`), `cos θ_i`, and for Mitsuba's spot and
    /// projector its texture (the id as an exact float, −1 for none: a
    /// NaN's bits need not survive a float load), frame axes and profile.
    GpuPunctualLight {
        tag: f32, position_x: f32, position_y: f32, position_z: f32,
        direction_x: f32, direction_y: f32, direction_z: f32, intensity_r: f32,
        intensity_g: f32, intensity_b: f32, cos_outer: f32, angle_scale: f32,
        pmf_mis: f32, pmf_bsdf: f32, cos_inner: f32, texture: f32,
        axis_x_x: f32, axis_x_y: f32, axis_x_z: f32, axis_y_x: f32,
        axis_y_y: f32, axis_y_z: f32, profile_0: f32, profile_1: f32,
        profile_2: f32, pad_a: f32, pad_b: f32, pad_c: f32,
    }
}

/// Floats of a [`GpuPunctualLight`] in `texels`.
pub const PUNCTUAL_LIGHT_WORDS: u32 = (std::mem::size_of::<GpuPunctualLight>() / 4) as u32;

/// Channels of a film pixel (R, G, B): the wave schedules' fold runs one
/// invocation per pixel and channel.
pub const FILM_CHANNELS: usize = 3;
/// Words of one channel's exact sums in [`GpuPixel::sums`]: `Σq` (4),
/// `Σq²` (6), `Σq³` (8), each least significant word first, the order of
/// `reference::film::PixelSums::to_words` (the WGSL's `ChannelSums`).
pub const FILM_CHANNEL_WORDS: usize = (reference::film::PIXEL_WORDS - 2) / FILM_CHANNELS;
/// Words of a pixel's sums: three channels.
pub const FILM_SUM_WORDS: usize = FILM_CHANNELS * FILM_CHANNEL_WORDS;

/// A pixel's exact sums (`reference::film::PixelSums`), as the GPU film
/// holds them (shaders/film.wgsl accumulates them): its words are
/// `PixelSums::to_words`'s. The film on the device is word-major (word
/// `w` of pixel `p` at `w · pixels + p`, [`film_words`]), so that the
/// kernels folding neighbouring pixels touch neighbouring words; this
/// record is one pixel's words gathered on the host.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuPixel {
    pub count: u32,
    pub rejected: u32,
    /// Per channel (R, G, B), [`FILM_CHANNEL_WORDS`] words.
    pub sums: [u32; FILM_SUM_WORDS],
}

impl Default for GpuPixel {
    fn default() -> Self {
        bytemuck::Zeroable::zeroed()
    }
}

/// Where a pixel's count, rejected count and sums start among its words
/// (`reference::film::PixelSums::to_words`).
pub const FILM_COUNT_WORD: usize = 0;
pub const FILM_REJECTED_WORD: usize = 1;
pub const FILM_SUMS_WORD: usize = 2;
/// Words of a pixel.
pub const FILM_PIXEL_WORDS: usize = std::mem::size_of::<GpuPixel>() / 4;

/// The device film's words for `pixels`: word-major, word `w` of pixel
/// `p` at `w · pixels.len() + p` (the WGSL's `film_at`).
pub fn film_words(pixels: &[GpuPixel]) -> Vec<u32> {
    let n = pixels.len();
    let mut out = vec![0u32; n * FILM_PIXEL_WORDS];
    for (p, px) in pixels.iter().enumerate() {
        let words: &[u32; FILM_PIXEL_WORDS] = bytemuck::cast_ref(px);
        for (w, &v) in words.iter().enumerate() {
            out[w * n + p] = v;
        }
    }
    out
}

/// The pixels of a device film's words ([`film_words`] undone), gathered
/// in blocks of pixels that stay in cache, in parallel.
pub fn film_pixels(words: &[u32]) -> Vec<GpuPixel> {
    use rayon::prelude::*;
    let n = words.len() / FILM_PIXEL_WORDS;
    let mut out = vec![GpuPixel::default(); n];
    const BLOCK: usize = 1024;
    out.par_chunks_mut(BLOCK)
        .enumerate()
        .for_each(|(b, block)| {
            let first = b * BLOCK;
            for w in 0..FILM_PIXEL_WORDS {
                let column = &words[w * n + first..w * n + first + block.len()];
                for (px, &v) in block.iter_mut().zip(column) {
                    bytemuck::cast_mut::<GpuPixel, [u32; FILM_PIXEL_WORDS]>(px)[w] = v;
                }
            }
        });
    out
}

impl GpuPixel {
    /// The reference's accumulator of the same sums (the record is
    /// `reference::film::PixelSums::to_words`'s words).
    pub fn to_sums(&self) -> reference::film::PixelSums {
        reference::film::PixelSums::from_words(bytemuck::cast_ref(self))
    }

    /// The record of the reference's sums ([`Self::to_sums`]'s inverse).
    pub fn from_sums(sums: &reference::film::PixelSums) -> Self {
        bytemuck::cast(sums.to_words())
    }
}

gpu_record! {
    /// Per-dispatch parameters (a uniform buffer): image, sample range,
    /// path settings, background, and the camera as `reference::Camera`
    /// computed it on the host (so both renderers start from the same floats).
    GpuParams {
        width: u32, height: u32, sample_start: u32, sample_count: u32,
        seed: u32, max_depth: u32, roulette_depth: u32, bg_tag: u32,
        bg_a_r: f32, bg_a_g: f32, bg_a_b: f32, bg_image: u32,
        bg_b_r: f32, bg_b_g: f32, bg_b_b: f32, bg_intensity: f32,
        lens_radius: f32, primitive_count: u32,
        cam_origin_x: f32, cam_origin_y: f32, cam_origin_z: f32,
        cam_upper_left_x: f32, cam_upper_left_y: f32, cam_upper_left_z: f32,
        cam_horizontal_x: f32, cam_horizontal_y: f32, cam_horizontal_z: f32,
        cam_vertical_x: f32, cam_vertical_y: f32, cam_vertical_z: f32,
        cam_u_x: f32, cam_u_y: f32, cam_u_z: f32,
        cam_v_x: f32, cam_v_y: f32, cam_v_z: f32,
        emitter_count: u32, env_pmf: f32, env_table: u32,
        // The punctual lights' records in `texels`, and the BSDF
        // estimator's light set (`LightSet::punctual_only`): its
        // `punctual_count` emitters follow the MIS set's in `emitters`.
        punctual_table: u32, punctual_count: u32,
        // A film band (gpu::film::film_bands): the film holds rows
        // `band_row .. band_row + height` of an image of `image_height`
        // rows; the camera and the randoms take a pixel's place in the
        // image, the film its place in the band.
        band_row: u32, image_height: u32,
        // The wavefront's wave (gpu::wavefront): its first pixel, its
        // pixel count, and the path slots its buffers hold.
        wave_pixel_start: u32, wave_pixel_count: u32, wave_capacity: u32,
        // The sequence of the paths' randoms (`reference::rng::Sampler::tag`).
        sampler: u32,
        // The camera's projection (`reference::camera::Projection::tag`)
        // and an orthographic camera's ray direction (`Camera::parallel`);
        // where the pixel filter's table starts in `texels`
        // (`NO_FILTER_TABLE`: the box).
        cam_projection: u32, cam_dir_x: f32, cam_dir_y: f32, cam_dir_z: f32,
        filter_table: u32,
        // An environment map's rotation into its frame
        // (`Background::Envmap::to_map`, rows) and its rows
        // (`EnvRows::tag`); then the padding to a multiple of 16 bytes.
        bg_map_xx: f32, bg_map_xy: f32, bg_map_xz: f32,
        bg_map_yx: f32, bg_map_yy: f32, bg_map_yz: f32,
        bg_map_zx: f32, bg_map_zy: f32, bg_map_zz: f32,
        bg_rows: u32, pad_b: u32, pad_c: u32,
    }
}

/// WGSL mirror of `reference::bvh::BvhNode` (defined in `reference`, the
/// one BVH; its layout is checked by the same layout test).
pub const BVH_NODE_WGSL: &str = "struct BvhNode {\n    min_x: f32,\n    min_y: f32,\n    min_z: f32,\n    index: u32,\n    max_x: f32,\n    max_y: f32,\n    max_z: f32,\n    meta_bits: u32,\n}\n";

/// Every record's WGSL, in one block.
pub fn wgsl_records() -> String {
    [
        GpuSphere::WGSL,
        GpuQuad::WGSL,
        GpuQuadric::WGSL,
        GpuTriangle::WGSL,
        GpuVertex::WGSL,
        GpuVertexExtra::WGSL,
        GpuPrimitive::WGSL,
        GpuMaterial::WGSL,
        GpuTexture::WGSL,
        GpuImage::WGSL,
        GpuEmitter::WGSL,
        GpuLightDensity::WGSL,
        GpuPunctualLight::WGSL,
        GpuParams::WGSL,
        BVH_NODE_WGSL,
    ]
    .concat()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn film_words_are_word_major_and_film_pixels_undo_them() {
        // 2,500 pixels: more than one gathering block, the last one short.
        let pixels: Vec<GpuPixel> = (0..2500u32)
            .map(|p| {
                let mut px = GpuPixel::default();
                for (w, v) in bytemuck::cast_mut::<GpuPixel, [u32; FILM_PIXEL_WORDS]>(&mut px)
                    .iter_mut()
                    .enumerate()
                {
                    *v = p * 1000 + w as u32;
                }
                px
            })
            .collect();
        let words = film_words(&pixels);
        assert_eq!(words[FILM_REJECTED_WORD * 2500 + 7], 7 * 1000 + 1);
        assert_eq!(words[(FILM_SUMS_WORD + 53) * 2500 + 2499], 2499 * 1000 + 55);
        assert_eq!(film_pixels(&words), pixels);
    }

    #[test]
    fn sizes_are_multiples_of_16_where_arrays_need_it() {
        assert_eq!(std::mem::size_of::<GpuSphere>(), 32);
        assert_eq!(std::mem::size_of::<GpuQuad>(), 48);
        // gpu::renderer binds 128 zero bytes for an empty array.
        assert_eq!(std::mem::size_of::<GpuQuadric>(), 128);
        assert_eq!(std::mem::size_of::<GpuTriangle>(), 32);
        assert_eq!(std::mem::size_of::<GpuVertex>(), 32);
        assert_eq!(std::mem::size_of::<GpuPrimitive>(), 32);
        assert_eq!(std::mem::size_of::<GpuVertexExtra>(), 48);
        assert_eq!(std::mem::size_of::<GpuMaterial>(), 148);
        assert_eq!(std::mem::size_of::<GpuTexture>(), 64);
        assert_eq!(std::mem::size_of::<GpuEmitter>(), 8);
        assert_eq!(std::mem::size_of::<GpuLightDensity>(), 8);
        assert_eq!(std::mem::size_of::<GpuPunctualLight>(), 112);
        assert_eq!(std::mem::size_of::<GpuPixel>(), 224);
        assert_eq!(FILM_PIXEL_WORDS, reference::film::PIXEL_WORDS);
        // Uniform buffers need a size that is a multiple of 16.
        assert_eq!(std::mem::size_of::<GpuParams>() % 16, 0);
        assert_eq!(
            GpuParams::FIELDS.len() * 4,
            std::mem::size_of::<GpuParams>()
        );
    }

    #[test]
    fn wgsl_mirror_lists_every_field() {
        assert!(GpuQuad::WGSL.starts_with("struct GpuQuad {\n    corner_x: f32,"));
        assert_eq!(GpuQuad::WGSL.matches(':').count(), GpuQuad::FIELDS.len());
    }
}
