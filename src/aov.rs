//! The AOV layers a render writes beside its image (`render --aov`) and
//! the viewer shows: what each means is `reference::aov`; this module
//! names them, parses the user's list and lays them out as EXR channels.
//!
//! | layer | EXR channels | meaning |
//! |---|---|---|
//! | `albedo` | `albedo.R`, `.G`, `.B` | the first hit's reflectance colour, mean over the pixel's samples (0 where a sample leaves the scene) |
//! | `normal` | `normal.X`, `.Y`, `.Z` | the shading normal facing the camera ray, world space, mean over the samples (0 for a miss) |
//! | `depth` | `depth.Z` | distance along the camera ray to the first hit, mean over the samples that hit; +∞ where none did |
//! | `position` | `position.X`, `.Y`, `.Z` | the first hit point, world space, mean over the samples that hit; 0 where none did |
//! | `samples` | `samples.count` (UINT) | the samples the image's pixel holds (non-finite samples are not counted) |

use anyhow::{bail, Result};
use glam::Vec3;
use reference::aov::AovLayers;
use reference::film::FilmSums;

/// One AOV layer of a render's EXR.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum AovLayer {
    Albedo,
    Normal,
    Depth,
    Position,
    Samples,
}

impl AovLayer {
    pub const ALL: [AovLayer; 5] = [
        AovLayer::Albedo,
        AovLayer::Normal,
        AovLayer::Depth,
        AovLayer::Position,
        AovLayer::Samples,
    ];

    pub fn name(self) -> &'static str {
        match self {
            AovLayer::Albedo => "albedo",
            AovLayer::Normal => "normal",
            AovLayer::Depth => "depth",
            AovLayer::Position => "position",
            AovLayer::Samples => "samples",
        }
    }

    /// Whether the layer is traced by the AOV pass (`samples` is the
    /// film's own count).
    pub fn traced(self) -> bool {
        self != AovLayer::Samples
    }

    /// `all`, or names separated by commas, each at most once.
    pub fn parse_list(s: &str) -> Result<Vec<AovLayer>> {
        if s.trim() == "all" {
            return Ok(Self::ALL.to_vec());
        }
        let mut out = Vec::new();
        for part in s.split(',') {
            let name = part.trim();
            let Some(layer) = Self::ALL.into_iter().find(|l| l.name() == name) else {
                let names: Vec<&str> = Self::ALL.iter().map(|l| l.name()).collect();
                bail!(
                    "--aov `{s}`: `{name}` is not a layer (the layers: {}, or all)",
                    names.join(", ")
                );
            };
            if out.contains(&layer) {
                bail!("--aov `{s}`: `{name}` is named twice");
            }
            out.push(layer);
        }
        out.sort();
        Ok(out)
    }
}

/// A layer's float channels: (name, one value a pixel).
pub type Channels = Vec<(String, Vec<f32>)>;

/// The float channels of `layers` (all but `samples`) from `aovs`, with
/// positions moved from render space to the scene's coordinates by
/// adding `origin`.
pub fn float_channels(layers: &[AovLayer], aovs: &AovLayers, origin: glam::DVec3) -> Channels {
    let mut out = Channels::new();
    let vec3 = |out: &mut Channels, name: &str, axes: [&str; 3], v: &[Vec3]| {
        for (c, axis) in axes.iter().enumerate() {
            out.push((format!("{name}.{axis}"), v.iter().map(|p| p[c]).collect()));
        }
    };
    for layer in layers {
        match layer {
            AovLayer::Albedo => vec3(&mut out, "albedo", ["R", "G", "B"], &aovs.albedo),
            AovLayer::Normal => vec3(&mut out, "normal", ["X", "Y", "Z"], &aovs.normal),
            AovLayer::Position => {
                let world: Vec<Vec3> = aovs
                    .position
                    .iter()
                    .zip(&aovs.hits)
                    .map(|(p, &hits)| {
                        if hits == 0 {
                            Vec3::ZERO
                        } else {
                            (p.as_dvec3() + origin).as_vec3()
                        }
                    })
                    .collect();
                vec3(&mut out, "position", ["X", "Y", "Z"], &world);
            }
            AovLayer::Depth | AovLayer::Samples => {}
        }
        if *layer == AovLayer::Depth {
            out.push(("depth.Z".into(), aovs.depth.clone()));
        }
    }
    out
}

/// The `samples` layer's channel of `pixels` pixels that each hold all
/// `spp` samples (a film with no sample rejected).
pub fn samples_channel_uniform(pixels: usize, spp: u32) -> (String, Vec<u32>) {
    ("samples.count".into(), vec![spp; pixels])
}

/// The `samples` layer's channel: each pixel's accepted samples.
pub fn samples_channel(sums: &FilmSums) -> (String, Vec<u32>) {
    (
        "samples.count".into(),
        sums.pixels.iter().map(|p| p.count).collect(),
    )
}

/// How the viewer draws a layer, as 8-bit RGB (row-major): albedo as
/// the image is drawn without tone mapping (clamped, sRGB); a normal `n`
/// as the codes of `(n + 1) / 2` (a miss mid-grey, as normal maps are
/// shown); depth from white at the nearest hit to black at the farthest
/// (a miss black); a position as its place in `bounds` (the scene's box
/// in render space, as the layer's points are); samples as grey, the most
/// white. `counts` is the `samples` layer's (`None`: black).
pub fn preview(
    layer: AovLayer,
    aovs: &AovLayers,
    bounds: (Vec3, Vec3),
    counts: Option<&[u32]>,
) -> Vec<u8> {
    let code = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
    let rgb = |v: &[Vec3], f: &dyn Fn(Vec3) -> Vec3| -> Vec<u8> {
        v.iter().flat_map(|&p| f(p).to_array().map(code)).collect()
    };
    let grey = |v: Vec<f32>| -> Vec<u8> { v.into_iter().flat_map(|x| [code(x); 3]).collect() };
    match layer {
        AovLayer::Albedo => crate::tonemap::Tonemap::None.to_srgb8_image(&aovs.albedo),
        AovLayer::Normal => rgb(&aovs.normal, &|n| (n + Vec3::ONE) * 0.5),
        AovLayer::Position => {
            let (lo, hi) = bounds;
            let extent = (hi - lo).max(Vec3::splat(f32::MIN_POSITIVE));
            rgb(&aovs.position, &|p| (p - lo) / extent)
        }
        AovLayer::Depth => {
            let finite = aovs.depth.iter().copied().filter(|d| d.is_finite());
            let (near, far) =
                finite.fold((f32::INFINITY, 0.0f32), |(n, f), d| (n.min(d), f.max(d)));
            let span = (far - near).max(f32::MIN_POSITIVE);
            grey(
                aovs.depth
                    .iter()
                    .map(|&d| {
                        if d.is_finite() {
                            1.0 - (d - near) / span
                        } else {
                            0.0
                        }
                    })
                    .collect(),
            )
        }
        AovLayer::Samples => {
            let counts = counts.unwrap_or(&[]);
            let most = counts.iter().copied().max().unwrap_or(0).max(1) as f32;
            let mut v: Vec<f32> = counts.iter().map(|&c| c as f32 / most).collect();
            v.resize(aovs.depth.len(), 0.0);
            grey(v)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_parse_strictly() {
        assert_eq!(AovLayer::parse_list("all").unwrap(), AovLayer::ALL);
        assert_eq!(
            AovLayer::parse_list("depth,albedo").unwrap(),
            [AovLayer::Albedo, AovLayer::Depth]
        );
        for bad in ["", "albedo,", "albedo,albedo", "colour", "ALL"] {
            let e = AovLayer::parse_list(bad).unwrap_err().to_string();
            assert!(e.starts_with("--aov") && !e.contains('\n'), "{bad}: {e}");
        }
    }

    #[test]
    fn channels_are_named_and_positions_moved() {
        let aovs = AovLayers {
            width: 2,
            height: 1,
            albedo: vec![Vec3::ONE; 2],
            normal: vec![Vec3::Z; 2],
            depth: vec![2.0, f32::INFINITY],
            position: vec![Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO],
            samples: vec![4, 4],
            hits: vec![4, 0],
        };
        let ch = float_channels(&AovLayer::ALL, &aovs, glam::DVec3::new(100.0, 0.0, -1.0));
        let names: Vec<&str> = ch.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(
            names,
            [
                "albedo.R",
                "albedo.G",
                "albedo.B",
                "normal.X",
                "normal.Y",
                "normal.Z",
                "depth.Z",
                "position.X",
                "position.Y",
                "position.Z"
            ]
        );
        let get = |n: &str| &ch.iter().find(|(m, _)| m == n).unwrap().1;
        assert_eq!(get("position.X"), &vec![101.0, 0.0]);
        assert_eq!(get("position.Z"), &vec![2.0, 0.0]);
        assert_eq!(get("depth.Z"), &vec![2.0, f32::INFINITY]);
        let bounds = (Vec3::ZERO, Vec3::splat(4.0));
        let normal = preview(AovLayer::Normal, &aovs, bounds, None);
        assert_eq!(normal[..3], [128, 128, 255]);
        let depth = preview(AovLayer::Depth, &aovs, bounds, None);
        assert_eq!(depth, [255, 255, 255, 0, 0, 0]);
        let position = preview(AovLayer::Position, &aovs, bounds, None);
        assert_eq!(position[..3], [64, 128, 191]);
        let samples = preview(AovLayer::Samples, &aovs, bounds, Some(&[2, 4]));
        assert_eq!(samples, [128, 128, 128, 255, 255, 255]);
        assert_eq!(preview(AovLayer::Albedo, &aovs, bounds, None), [255; 6]);
    }
}
