//! Textures: a closed set evaluated at a surface point.

use glam::{Vec2, Vec3};

/// A decoded image in linear RGB, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageData {
    pub width: u32,
    pub height: u32,
    /// `width * height` linear RGB texels, row-major from the top row.
    pub texels: Vec<Vec3>,
}

impl ImageData {
    #[inline]
    pub fn texel(&self, x: u32, y: u32) -> Vec3 {
        self.texels[(y * self.width + x) as usize]
    }

    /// Bilinear lookup with repeat wrapping. `uv = (0, 0)` is the bottom-left
    /// corner of the image and `(1, 1)` the top-right (the convention of
    /// Ray Tracing: The Next Week; the glTF loader flips v on import).
    pub fn sample_bilinear(&self, uv: Vec2) -> Vec3 {
        self.sample_image(uv, &Sampler::default())
    }

    /// The lookup `sampler` describes at `uv` (already transformed:
    /// [`Sampler::transformed_uv`]): each axis wrapped by its mode, then
    /// the nearest texel or bilinear filtering (texel centres at
    /// half-integers, as in glTF and OpenGL).
    pub fn sample_image(&self, uv: Vec2, sampler: &Sampler) -> Vec3 {
        let (x, y) = self.texel_space(uv, sampler);
        if sampler.nearest {
            let xi = sampler.wrap_u.wrap_index((x + 0.5).floor(), self.width);
            let yi = sampler.wrap_v.wrap_index((y + 0.5).floor(), self.height);
            return self.texel(xi, yi);
        }
        let ([xa, xb], [ya, yb], fx, fy) = self.bilinear_square(x, y, sampler);
        let top = self.texel(xa, ya).lerp(self.texel(xb, ya), fx);
        let bottom = self.texel(xa, yb).lerp(self.texel(xb, yb), fx);
        top.lerp(bottom, fy)
    }

    /// The point `uv` (already transformed) in texel units: each axis
    /// wrapped by its mode, texel centres at half-integers, y down the
    /// rows.
    #[inline]
    fn texel_space(&self, uv: Vec2, sampler: &Sampler) -> (f32, f32) {
        let x = sampler.wrap_u.wrap_coordinate(uv.x) * self.width as f32 - 0.5;
        let y = (1.0 - sampler.wrap_v.wrap_coordinate(uv.y)) * self.height as f32 - 0.5;
        (x, y)
    }

    /// The four texels around (`x`, `y`) in texel units (columns, rows,
    /// wrapped) and the point's fractions across and down the square.
    #[inline]
    fn bilinear_square(&self, x: f32, y: f32, sampler: &Sampler) -> ([u32; 2], [u32; 2], f32, f32) {
        let (x0, y0) = (x.floor(), y.floor());
        let (wrap_u, wrap_v) = (sampler.wrap_u, sampler.wrap_v);
        (
            [
                wrap_u.wrap_index(x0, self.width),
                wrap_u.wrap_index(x0 + 1.0, self.width),
            ],
            [
                wrap_v.wrap_index(y0, self.height),
                wrap_v.wrap_index(y0 + 1.0, self.height),
            ],
            x - x0,
            y - y0,
        )
    }

    /// The gradient per unit of `uv` (already transformed) of the
    /// one-channel value ([`one_channel`]) of [`Self::sample_image`]
    /// times `factor` (a grey factor, a bump map's scale, multiplies the
    /// image's gradient, as Mitsuba's `bumpmap` scales its texture's):
    /// Mitsuba's `eval_1_grad` of a bitmap. Bilinear
    /// filtering's derivative inside the texel square the point lies in
    /// (each axis's difference of the one-channel texels, weighed along
    /// the other axis), times the image's size along it and the wrap's
    /// slope there (−1 in a mirrored copy); v runs up the image, against
    /// its rows. The nearest texel's is zero, as Mitsuba's.
    pub fn gradient(&self, uv: Vec2, sampler: &Sampler, factor: Vec3) -> Vec2 {
        if sampler.nearest {
            return Vec2::ZERO;
        }
        let (x, y) = self.texel_space(uv, sampler);
        let ([xa, xb], [ya, yb], fx, fy) = self.bilinear_square(x, y, sampler);
        let grey = factor.x == factor.y && factor.y == factor.z;
        let f = |x, y| {
            let c = self.texel(x, y);
            one_channel(if grey { c } else { factor * c })
        };
        let (f00, f10, f01, f11) = (f(xa, ya), f(xb, ya), f(xa, yb), f(xb, yb));
        let df_dx = (1.0 - fy) * (f10 - f00) + fy * (f11 - f01);
        let df_dy = (1.0 - fx) * (f01 - f00) + fx * (f11 - f10);
        let g = Vec2::new(
            self.width as f32 * df_dx * sampler.wrap_u.slope(uv.x),
            -(self.height as f32) * df_dy * sampler.wrap_v.slope(uv.y),
        );
        if grey {
            g * factor.x
        } else {
            g
        }
    }
}

/// Mitsuba's luminance weights (its rgb variants' `luminance`, CIE Y of
/// linear sRGB), which its `eval_1` of a colour bitmap reads.
pub const MITSUBA_LUMINANCE: [f32; 3] = [0.212671, 0.715160, 0.072169];

/// A colour's one-channel value as Mitsuba's `eval_1` reads a texture:
/// the value where the channels agree (a grey image or a number, which
/// Mitsuba holds as one channel), else its luminance by
/// [`MITSUBA_LUMINANCE`].
#[inline]
pub fn one_channel(c: Vec3) -> f32 {
    if c.x == c.y && c.y == c.z {
        c.x
    } else {
        c.dot(Vec3::from_array(MITSUBA_LUMINANCE))
    }
}

/// How an image's coordinates continue outside [0, 1] along one axis
/// (glTF's sampler `wrapS` / `wrapT`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Wrap {
    /// The image tiles.
    #[default]
    Repeat,
    /// The edge texels extend.
    ClampToEdge,
    /// The image tiles, every other copy mirrored.
    MirroredRepeat,
}

/// Numeric tags of [`Wrap`], shared with the GPU.
pub mod wrap_tag {
    pub const REPEAT: u32 = 0;
    pub const CLAMP_TO_EDGE: u32 = 1;
    pub const MIRRORED_REPEAT: u32 = 2;
}

impl Wrap {
    pub fn tag(self) -> u32 {
        match self {
            Wrap::Repeat => wrap_tag::REPEAT,
            Wrap::ClampToEdge => wrap_tag::CLAMP_TO_EDGE,
            Wrap::MirroredRepeat => wrap_tag::MIRRORED_REPEAT,
        }
    }

    /// A texture coordinate brought into [0, 1].
    #[inline]
    pub fn wrap_coordinate(self, c: f32) -> f32 {
        match self {
            Wrap::Repeat => c.rem_euclid(1.0),
            Wrap::ClampToEdge => c.clamp(0.0, 1.0),
            Wrap::MirroredRepeat => {
                let t = c.rem_euclid(2.0);
                if t > 1.0 {
                    2.0 - t
                } else {
                    t
                }
            }
        }
    }

    /// The derivative of [`Self::wrap_coordinate`] at `c`: −1 in a
    /// mirrored copy, else 1 (clamping's 0 beyond the edge needs no
    /// factor: the texels it reads there are one).
    #[inline]
    pub fn slope(self, c: f32) -> f32 {
        match self {
            Wrap::MirroredRepeat if c.rem_euclid(2.0) > 1.0 => -1.0,
            _ => 1.0,
        }
    }

    /// A texel index `i` (a whole number, perhaps outside the image)
    /// brought into `0..n`.
    #[inline]
    pub fn wrap_index(self, i: f32, n: u32) -> u32 {
        let (i, n) = (i as i64, n as i64);
        let k = match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::ClampToEdge => i.clamp(0, n - 1),
            Wrap::MirroredRepeat => {
                let m = i.rem_euclid(2 * n);
                if m >= n {
                    2 * n - 1 - m
                } else {
                    m
                }
            }
        };
        k as u32
    }
}

/// How an image texture is looked up: an affine map of the surface's uv
/// first (glTF's `KHR_texture_transform`), each axis's wrap mode, and the
/// filter (glTF's sampler; the default: repeat, bilinear, uv as is).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sampler {
    pub wrap_u: Wrap,
    pub wrap_v: Wrap,
    /// The nearest texel instead of bilinear filtering (glTF's
    /// `magFilter` NEAREST).
    pub nearest: bool,
    /// `uv' = (t0·u + t1·v + t2, t3·u + t4·v + t5)` in the renderer's uv
    /// convention (v up); `None`: uv as is.
    pub transform: Option<[f32; 6]>,
    /// Which set of the surface's texture coordinates it reads, 0 or 1
    /// (glTF's `texCoord`).
    pub tex_coord: u32,
}

impl Sampler {
    /// The coordinates the texture reads at a point whose two sets are
    /// `uvs`: its set, transformed.
    #[inline]
    pub fn coordinates(&self, uvs: [Vec2; 2]) -> Vec2 {
        let uv = if self.tex_coord == 1 { uvs[1] } else { uvs[0] };
        self.transformed_uv(uv)
    }

    /// `uv` as the texture reads it.
    #[inline]
    pub fn transformed_uv(&self, uv: Vec2) -> Vec2 {
        match self.transform {
            None => uv,
            Some(t) => Vec2::new(
                t[0] * uv.x + t[1] * uv.y + t[2],
                t[3] * uv.x + t[4] * uv.y + t[5],
            ),
        }
    }
}

/// A texture. Colour fields of materials are all textures; a plain colour
/// is `Constant`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Texture {
    Constant(Vec3),
    /// The 3-D sine checker of Ray Tracing: The Next Week:
    /// `sin(scale·x)·sin(scale·y)·sin(scale·z) < 0` → `odd`, else `even`.
    /// `even`/`odd` are texture indices (constant or image, not checker).
    Checker {
        scale: f32,
        even: u32,
        odd: u32,
    },
    /// An image, multiplied by `factor` (glTF's base colour factor, say),
    /// looked up as `sampler` says.
    Image {
        image: u32,
        factor: Vec3,
        sampler: Sampler,
    },
    /// Squares in texture space (Mitsuba's `checkerboard`): `even` (its
    /// `color0`) where the fractional parts of the coordinates `sampler`
    /// reads (its set, transformed; its wrap modes and filter are not
    /// used) are both above ½ or both at most ½, `odd` elsewhere.
    /// `even`/`odd` are texture indices (constant or image, no checker).
    UvChecker {
        sampler: Sampler,
        even: u32,
        odd: u32,
    },
    /// The mesh's vertex colour at the point
    /// ([`crate::geometry::SurfaceInteraction::color`]: interpolated, one
    /// where the shape has none) times `factor`: Mitsuba's
    /// `mesh_attribute` of a mesh attribute the reader makes its vertex
    /// colours. Not one of a pattern's two.
    VertexColor {
        factor: Vec3,
    },
}

/// Rec. 709 / sRGB luminance weights of linear R, G, B.
pub const LUMINANCE_WEIGHTS: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// Texture `id`'s mean, one number (Mitsuba's `Texture::mean` in its rgb
/// variants, which weighs a plastic's sampling of its two lobes): a
/// constant's channels' mean, an image's mean luminance
/// (Rec. 709's weights, [`LUMINANCE_WEIGHTS`], times its
/// factor), a pattern's
/// two textures' mean.
pub fn texture_mean(textures: &[Texture], images: &[ImageData], id: u32) -> f32 {
    match textures[id as usize] {
        Texture::Constant(c) => (c.x + c.y + c.z) / 3.0,
        Texture::Image { image, factor, .. } => {
            let texels = &images[image as usize].texels;
            let weights = Vec3::from_array(LUMINANCE_WEIGHTS);
            let sum: f64 = texels
                .iter()
                .map(|&t| f64::from(weights.dot(t * factor)))
                .sum();
            (sum / texels.len().max(1) as f64) as f32
        }
        Texture::Checker { even, odd, .. } | Texture::UvChecker { even, odd, .. } => {
            0.5 * (texture_mean(textures, images, even) + texture_mean(textures, images, odd))
        }
        // The builder refuses a mean of one (SceneBuilder::texture_mean): the
        // factor's, for a caller that asks apart.
        Texture::VertexColor { factor } => (factor.x + factor.y + factor.z) / 3.0,
    }
}

/// Numeric tags of [`Texture`], shared with the GPU.
pub mod texture_tag {
    pub const CONSTANT: u32 = 0;
    pub const CHECKER: u32 = 1;
    pub const IMAGE: u32 = 2;
    pub const UV_CHECKER: u32 = 3;
    pub const VERTEX_COLOR: u32 = 4;
}

impl Texture {
    pub fn tag(&self) -> u32 {
        match self {
            Texture::Constant(_) => texture_tag::CONSTANT,
            Texture::Checker { .. } => texture_tag::CHECKER,
            Texture::Image { .. } => texture_tag::IMAGE,
            Texture::UvChecker { .. } => texture_tag::UV_CHECKER,
            Texture::VertexColor { .. } => texture_tag::VERTEX_COLOR,
        }
    }

    /// A pattern of two other textures (a checker), which cannot be one
    /// of a pattern's two.
    pub fn is_pattern(&self) -> bool {
        matches!(self, Texture::Checker { .. } | Texture::UvChecker { .. })
    }
}

/// Which of a [`Texture::UvChecker`]'s two textures covers coordinates
/// `uv`: true for `even`.
#[inline]
pub fn uv_checker_even(uv: Vec2) -> bool {
    (uv.x - uv.x.floor() > 0.5) == (uv.y - uv.y.floor() > 0.5)
}

/// Evaluates texture `id` at point `p` whose texture coordinates (both
/// sets) are `uvs` and vertex colour `color`.
pub fn evaluate_texture(
    textures: &[Texture],
    images: &[ImageData],
    id: u32,
    p: Vec3,
    uvs: [Vec2; 2],
    color: Vec3,
) -> Vec3 {
    match textures[id as usize] {
        Texture::Constant(c) => c,
        Texture::VertexColor { factor } => factor * color,
        Texture::Checker { scale, even, odd } => {
            let sines = (scale * p.x).sin() * (scale * p.y).sin() * (scale * p.z).sin();
            let pick = if sines < 0.0 { odd } else { even };
            evaluate_leaf(textures, images, pick, uvs)
        }
        Texture::Image {
            image,
            factor,
            sampler,
        } => factor * images[image as usize].sample_image(sampler.coordinates(uvs), &sampler),
        Texture::UvChecker { sampler, even, odd } => {
            let pick = if uv_checker_even(sampler.coordinates(uvs)) {
                even
            } else {
                odd
            };
            evaluate_leaf(textures, images, pick, uvs)
        }
    }
}

/// The gradient per unit of uv (the first set's: a bump map's, as
/// Mitsuba's one set) of texture `id`'s one-channel value, Mitsuba's
/// `eval_1_grad`: an image's ([`ImageData::gradient`]) taken back through
/// its sampler's transform; zero for a constant. The scene builder lets
/// only those two be bump maps.
pub fn texture_gradient(
    textures: &[Texture],
    images: &[ImageData],
    id: u32,
    uvs: [Vec2; 2],
) -> Vec2 {
    match textures[id as usize] {
        Texture::Image {
            image,
            factor,
            sampler,
        } => {
            let g = images[image as usize].gradient(sampler.coordinates(uvs), &sampler, factor);
            match sampler.transform {
                None => g,
                Some(t) => Vec2::new(t[0] * g.x + t[3] * g.y, t[1] * g.x + t[4] * g.y),
            }
        }
        _ => Vec2::ZERO,
    }
}

fn evaluate_leaf(textures: &[Texture], images: &[ImageData], id: u32, uvs: [Vec2; 2]) -> Vec3 {
    match textures[id as usize] {
        Texture::Constant(c) => c,
        Texture::Image {
            image,
            factor,
            sampler,
        } => factor * images[image as usize].sample_image(sampler.coordinates(uvs), &sampler),
        // The scene builder rejects checkers and vertex colours in
        // checkers.
        Texture::Checker { .. } | Texture::UvChecker { .. } | Texture::VertexColor { .. } => {
            Vec3::ZERO
        }
    }
}

/// The linear value of an 8-bit channel: sRGB-encoded colour
/// (`srgb`) or data (`c / 255`). The loaders decode 8-bit images through
/// this table, and the GPU stores such images as the bytes and the table.
pub fn decode_8bit(c: u8, srgb: bool) -> f32 {
    let v = c as f32 / 255.0;
    if srgb {
        srgb_to_linear(v)
    } else {
        v
    }
}

/// sRGB transfer function to linear (IEC 61966-2-1).
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn two_by_two() -> ImageData {
        // top row: red, green; bottom row: blue, white
        ImageData {
            width: 2,
            height: 2,
            texels: vec![Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE],
        }
    }

    #[test]
    fn image_lookup_at_texel_centres_and_orientation() {
        let img = two_by_two();
        // v = 0 is the bottom row.
        assert_eq!(img.sample_bilinear(Vec2::new(0.25, 0.25)), Vec3::Z);
        assert_eq!(img.sample_bilinear(Vec2::new(0.75, 0.25)), Vec3::ONE);
        assert_eq!(img.sample_bilinear(Vec2::new(0.25, 0.75)), Vec3::X);
        assert_eq!(img.sample_bilinear(Vec2::new(0.75, 0.75)), Vec3::Y);
        // Halfway between red and green, and wrapping across the border.
        let mid = img.sample_bilinear(Vec2::new(0.5, 0.75));
        assert_relative_eq!(mid.x, 0.5);
        assert_relative_eq!(mid.y, 0.5);
        let wrapped = img.sample_bilinear(Vec2::new(1.0, 0.75));
        assert_relative_eq!(wrapped.x, 0.5);
        assert_eq!(img.sample_bilinear(Vec2::new(1.25, 1.25)), Vec3::Z);
    }

    #[test]
    fn wrap_modes_fold_coordinates_and_indices() {
        use Wrap::*;
        for (c, repeat, clamp, mirror) in [
            (0.25, 0.25, 0.25, 0.25),
            (1.25, 0.25, 1.0, 0.75),
            (-0.25, 0.75, 0.0, 0.25),
            (2.5, 0.5, 1.0, 0.5),
            (-1.25, 0.75, 0.0, 0.75),
        ] {
            assert_eq!(Repeat.wrap_coordinate(c), repeat, "{c}");
            assert_eq!(ClampToEdge.wrap_coordinate(c), clamp, "{c}");
            assert_eq!(MirroredRepeat.wrap_coordinate(c), mirror, "{c}");
        }
        // Four texels: index -1 is the last (repeat), the first (clamp),
        // the first again (mirror: ... 1 0 | 0 1 2 3 | 3 2 ...).
        for (i, repeat, clamp, mirror) in [
            (-1.0, 3, 0, 0),
            (-2.0, 2, 0, 1),
            (4.0, 0, 3, 3),
            (5.0, 1, 3, 2),
            (8.0, 0, 3, 0),
        ] {
            assert_eq!(Repeat.wrap_index(i, 4), repeat, "{i}");
            assert_eq!(ClampToEdge.wrap_index(i, 4), clamp, "{i}");
            assert_eq!(MirroredRepeat.wrap_index(i, 4), mirror, "{i}");
        }
    }

    #[test]
    fn samplers_clamp_mirror_filter_and_transform() {
        let img = two_by_two(); // top: red, green; bottom: blue, white
        let clamp = Sampler {
            wrap_u: Wrap::ClampToEdge,
            wrap_v: Wrap::ClampToEdge,
            ..Sampler::default()
        };
        // Past the right edge: the right column, not the left.
        assert_eq!(img.sample_image(Vec2::new(1.5, 0.25), &clamp), Vec3::ONE);
        assert_eq!(img.sample_image(Vec2::new(1.0, 0.75), &clamp), Vec3::Y);
        // Mirrored: 1.25 reads as 0.75.
        let mirror = Sampler {
            wrap_u: Wrap::MirroredRepeat,
            ..Sampler::default()
        };
        assert_eq!(img.sample_image(Vec2::new(1.25, 0.75), &mirror), Vec3::Y);
        // Nearest: no blend halfway between red and green.
        let nearest = Sampler {
            nearest: true,
            ..Sampler::default()
        };
        assert_eq!(img.sample_image(Vec2::new(0.49, 0.75), &nearest), Vec3::X);
        assert_eq!(img.sample_image(Vec2::new(0.51, 0.75), &nearest), Vec3::Y);
        // A transform: u' = u + 0.5 moves red's quarter to green's.
        let shifted = Sampler {
            transform: Some([1.0, 0.0, 0.5, 0.0, 1.0, 0.0]),
            ..Sampler::default()
        };
        assert_eq!(
            img.sample_image(shifted.transformed_uv(Vec2::new(0.25, 0.75)), &shifted),
            Vec3::Y
        );
        // The default sampler is the plain bilinear repeat lookup.
        for uv in [
            Vec2::new(0.1, 0.9),
            Vec2::new(-3.3, 7.7),
            Vec2::new(0.5, 0.5),
        ] {
            assert_eq!(
                img.sample_image(uv, &Sampler::default()),
                img.sample_bilinear(uv)
            );
        }
    }

    #[test]
    fn uv_checker_squares_follow_the_transformed_coordinates() {
        let textures = [
            Texture::Constant(Vec3::ONE),
            Texture::Constant(Vec3::ZERO),
            Texture::UvChecker {
                // Five squares a unit along u and v (Mitsuba's `<scale
                // x="5" y="5"/>`), from the second set.
                sampler: Sampler {
                    transform: Some([5.0, 0.0, 0.0, 0.0, 5.0, 0.0]),
                    tex_coord: 1,
                    ..Sampler::default()
                },
                even: 0,
                odd: 1,
            },
        ];
        let at = |u: f32, v: f32| {
            evaluate_texture(
                &textures,
                &[],
                2,
                Vec3::ZERO,
                [Vec2::ZERO, Vec2::new(u, v)],
                Vec3::ONE,
            )
        };
        // Both fractional parts at most ½ (0.05 · 5 = 0.25): even.
        assert_eq!(at(0.05, 0.05), Vec3::ONE);
        // Both above ½: even; one above: odd.
        assert_eq!(at(0.15, 0.15), Vec3::ONE);
        assert_eq!(at(0.15, 0.05), Vec3::ZERO);
        assert_eq!(at(0.05, 0.15), Vec3::ZERO);
        // Negative coordinates: the fractional part of −0.25 · 5 is 0.75.
        assert_eq!(at(-0.05, 0.15), Vec3::ONE);
        // A fractional part of exactly ½ is not above it (0.1 · 5 rounds
        // to 0.5 in f32).
        assert_eq!(at(0.1, 0.05), Vec3::ONE);
    }

    #[test]
    fn checker_alternates_with_sign_of_sines() {
        let textures = [
            Texture::Constant(Vec3::ONE),
            Texture::Constant(Vec3::ZERO),
            Texture::Checker {
                scale: 1.0,
                even: 0,
                odd: 1,
            },
        ];
        let p_even = Vec3::splat(1.0); // sin(1)^3 > 0
        let p_odd = Vec3::new(-1.0, 1.0, 1.0);
        assert_eq!(
            evaluate_texture(&textures, &[], 2, p_even, [Vec2::ZERO; 2], Vec3::ONE),
            Vec3::ONE
        );
        assert_eq!(
            evaluate_texture(&textures, &[], 2, p_odd, [Vec2::ZERO; 2], Vec3::ONE),
            Vec3::ZERO
        );
    }

    #[test]
    fn image_texture_applies_factor() {
        let textures = [Texture::Image {
            image: 0,
            factor: Vec3::splat(0.5),
            sampler: Sampler::default(),
        }];
        let c = evaluate_texture(
            &textures,
            &[two_by_two()],
            0,
            Vec3::ZERO,
            [Vec2::new(0.75, 0.25), Vec2::ZERO],
            Vec3::ONE,
        );
        assert_eq!(c, Vec3::splat(0.5));
    }

    #[test]
    fn a_texture_reads_the_coordinate_set_its_sampler_names() {
        let img = two_by_two();
        let uvs = [Vec2::new(0.25, 0.25), Vec2::new(0.75, 0.75)];
        let read = |tex_coord| {
            let textures = [Texture::Image {
                image: 0,
                factor: Vec3::ONE,
                sampler: Sampler {
                    tex_coord,
                    ..Sampler::default()
                },
            }];
            evaluate_texture(
                &textures,
                std::slice::from_ref(&img),
                0,
                Vec3::ZERO,
                uvs,
                Vec3::ONE,
            )
        };
        assert_eq!(read(0), Vec3::Z);
        assert_eq!(read(1), Vec3::Y);
    }

    #[test]
    fn srgb_endpoints() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert_relative_eq!(srgb_to_linear(1.0), 1.0, epsilon = 1e-6);
        assert_relative_eq!(srgb_to_linear(0.5), 0.214_041, epsilon = 1e-5);
    }

    /// A 5 x 4 image of distinct colours, grey (`grey`) or not.
    fn ramp(grey: bool) -> ImageData {
        let texels = (0..20)
            .map(|k| {
                let v = ((k * 7) % 20) as f32 / 20.0;
                if grey {
                    Vec3::splat(v)
                } else {
                    Vec3::new(v, 1.0 - v, (k % 3) as f32 / 3.0)
                }
            })
            .collect();
        ImageData {
            width: 5,
            height: 4,
            texels,
        }
    }

    #[test]
    fn image_gradients_are_the_lookups_derivatives() {
        // Central differences of the one-channel value of the lookup, at
        // points inside a texel square (away from where bilinear
        // filtering's derivative jumps), against the analytic gradient:
        // each wrap mode, in a mirrored copy, through a transform, a
        // colour image (its luminance) and a factor.
        let h = 1e-3f32;
        for grey in [true, false] {
            let img = ramp(grey);
            for wrap in [Wrap::Repeat, Wrap::MirroredRepeat, Wrap::ClampToEdge] {
                for transform in [None, Some([1.5, 0.3, 0.1, -0.4, 2.0, 0.2])] {
                    let sampler = Sampler {
                        wrap_u: wrap,
                        wrap_v: wrap,
                        transform,
                        ..Sampler::default()
                    };
                    let textures = [Texture::Image {
                        image: 0,
                        factor: Vec3::splat(0.7),
                        sampler,
                    }];
                    let images = std::slice::from_ref(&img);
                    let value = |uv: Vec2| {
                        one_channel(evaluate_texture(
                            &textures,
                            images,
                            0,
                            Vec3::ZERO,
                            [uv, Vec2::ZERO],
                            Vec3::ONE,
                        ))
                    };
                    for uv in [
                        Vec2::new(0.33, 0.41),
                        Vec2::new(1.37, -0.29),
                        Vec2::new(0.61, 0.87),
                    ] {
                        let g = texture_gradient(&textures, images, 0, [uv, Vec2::ZERO]);
                        let du = (value(uv + Vec2::X * h) - value(uv - Vec2::X * h)) / (2.0 * h);
                        let dv = (value(uv + Vec2::Y * h) - value(uv - Vec2::Y * h)) / (2.0 * h);
                        // The differences' own rounding: 8-bit-scale values
                        // over 2e-3, some 1e-4 relative of gradients of
                        // order 1-10.
                        let close = |a: f32, b: f32| (a - b).abs() <= 0.02 + 0.01 * b.abs();
                        assert!(
                            close(g.x, du) && close(g.y, dv),
                            "grey {grey}, {wrap:?}, {transform:?}, uv {uv}: {g} vs ({du}, {dv})"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn the_nearest_texel_and_a_constant_have_no_gradient() {
        let img = ramp(true);
        let textures = [
            Texture::Image {
                image: 0,
                factor: Vec3::ONE,
                sampler: Sampler {
                    nearest: true,
                    ..Sampler::default()
                },
            },
            Texture::Constant(Vec3::splat(0.5)),
        ];
        for id in 0..2 {
            let g = texture_gradient(
                &textures,
                std::slice::from_ref(&img),
                id,
                [Vec2::splat(0.3); 2],
            );
            assert_eq!(g, Vec2::ZERO);
        }
    }
}
