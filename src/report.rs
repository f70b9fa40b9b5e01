//! The self-contained HTML report of a comparison: one file, no external
//! resources, images embedded as base64 PNG data URIs, so it opens in any
//! browser and survives being attached to a CI run.
//!
//! It shows the render and the reference (ACES tone mapped), an error
//! heat map (`mean_c |a − b|`, black at 0, white at the image's largest
//! error), the signed test statistic (blue −5 … white 0 … red +5: the
//! channel with the largest `|z|` or `|t|`), the FLIP error map (magma),
//! the p-value map (grey `−log₁₀ p` up to the per-test Šidák level; red:
//! the pixel failed; yellow outlines: failing tiles), and a table with the
//! verdict, every test and the metrics.

use crate::compare::image::{NoisyImage, Verdict};
use crate::compare::metrics::{flip_map, mean_f32, Metrics};
use crate::image_io;
use crate::stats;
use crate::tonemap::Tonemap;
use anyhow::Result;
use std::fmt::Write as _;
use std::path::Path;

/// What a report shows.
pub struct Report<'a> {
    pub title: String,
    /// Names of the two images, `[render, reference]`.
    pub labels: [String; 2],
    pub a: &'a NoisyImage,
    pub b: &'a NoisyImage,
    /// `None` when no statistical test could run (no variance).
    pub verdict: Option<&'a Verdict>,
    pub metrics: &'a Metrics,
    /// Extra rows for the table: settings, provenance.
    pub notes: Vec<(String, String)>,
}

/// Standard base64 (RFC 4648, with padding).
pub fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// HTML-escapes text.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// An 8-bit RGB image as a `data:image/png;base64,…` URI.
fn png_data_uri(width: u32, height: u32, rgb: &[u8]) -> Result<String> {
    use image::ImageEncoder;
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png).write_image(
        rgb,
        width,
        height,
        image::ExtendedColorType::Rgb8,
    )?;
    Ok(format!("data:image/png;base64,{}", base64(&png)))
}

fn lerp_colour(stops: &[[f32; 3]], t: f32) -> [u8; 3] {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        1.0
    };
    let x = t * (stops.len() - 1) as f32;
    let i = (x.floor() as usize).min(stops.len() - 2);
    let f = x - i as f32;
    [0, 1, 2].map(|c| ((stops[i][c] * (1.0 - f) + stops[i + 1][c] * f) * 255.0).round() as u8)
}

/// Black → purple → orange → white, for magnitudes.
const HEAT: [[f32; 3]; 5] = [
    [0.0, 0.0, 0.0],
    [0.35, 0.05, 0.5],
    [0.85, 0.25, 0.3],
    [1.0, 0.7, 0.2],
    [1.0, 1.0, 1.0],
];
/// Blue → white → red, for signed statistics.
const DIVERGING: [[f32; 3]; 3] = [[0.15, 0.3, 0.85], [1.0, 1.0, 1.0], [0.85, 0.15, 0.1]];

/// The images of the report, each with a caption.
fn figures(r: &Report) -> Result<Vec<(String, String)>> {
    let (w, h) = (r.a.width, r.a.height);
    let mut out = Vec::new();
    let (ma, mb) = (mean_f32(r.a), mean_f32(r.b));
    out.push((
        format!("{} (ACES)", r.labels[0]),
        png_data_uri(w, h, &Tonemap::Aces.to_srgb8_image(&sanitized(&ma)))?,
    ));
    out.push((
        format!("{} (ACES)", r.labels[1]),
        png_data_uri(w, h, &Tonemap::Aces.to_srgb8_image(&sanitized(&mb)))?,
    ));

    let err: Vec<f64> =
        r.a.mean
            .iter()
            .zip(&r.b.mean)
            .map(|(p, q)| (*p - *q).abs().element_sum() / 3.0)
            .collect();
    let max_err = err
        .iter()
        .copied()
        .filter(|e| e.is_finite())
        .fold(0.0f64, f64::max);
    let heat: Vec<u8> = err
        .iter()
        .flat_map(|&e| {
            lerp_colour(
                &HEAT,
                if max_err > 0.0 {
                    (e / max_err) as f32
                } else {
                    0.0
                },
            )
        })
        .collect();
    out.push((
        format!("error |a − b|, mean over channels: black 0, white {max_err:.3e}"),
        png_data_uri(w, h, &heat)?,
    ));

    if let Some(v) = r.verdict {
        let stat: Vec<u8> = v
            .pixels
            .statistic
            .iter()
            .flat_map(|s| {
                let c = (0..3)
                    .max_by(|&i, &j| s[i].abs().total_cmp(&s[j].abs()))
                    .unwrap_or(0);
                let t = if s[c].is_nan() {
                    1.0
                } else {
                    (s[c] / 5.0).clamp(-1.0, 1.0) * 0.5 + 0.5
                };
                lerp_colour(&DIVERGING, t as f32)
            })
            .collect();
        out.push((
            "test statistic (largest |z| or |t| of R, G, B): blue −5, white 0, red +5".into(),
            png_data_uri(w, h, &stat)?,
        ));
    }

    let flip = flip_map(w, h, &ma, &mb);
    let flip_rgb = nv_flip::FlipImageFloat::with_data(w, h, &flip)
        .apply_color_lut(&nv_flip::magma_lut())
        .to_vec();
    out.push((
        format!(
            "FLIP (ACES tone mapped, magma: 0 black … 1 yellow-white); mean {:.4}",
            r.metrics.flip_mean
        ),
        png_data_uri(w, h, &flip_rgb)?,
    ));

    if let Some(v) = r.verdict {
        let level = -v.pixels.alpha_per_test.log10();
        let mut rgb: Vec<u8> = (0..v.pixels.p.len())
            .flat_map(|i| {
                let p = v.pixels.p[i];
                if (0..3).all(|c| v.pixels.passed_at(i, c)) {
                    let q = -p.min_element().max(1e-300).log10();
                    let g = ((q / level).clamp(0.0, 1.0) * 200.0) as u8;
                    [g, g, g]
                } else {
                    [255, 40, 40]
                }
            })
            .collect();
        for t in v.aggregate.failing_tiles() {
            for y in t.y0..t.y1 {
                for x in t.x0..t.x1 {
                    if x == t.x0 || x + 1 == t.x1 || y == t.y0 || y + 1 == t.y1 {
                        let i = 3 * (y * w + x) as usize;
                        rgb[i..i + 3].copy_from_slice(&[255, 220, 0]);
                    }
                }
            }
        }
        out.push((
            format!("p-value: grey −log₁₀ p (white at the per-test level {:.1e}); red: failed; yellow outline: failing tile", v.pixels.alpha_per_test),
            png_data_uri(w, h, &rgb)?,
        ));
    }
    Ok(out)
}

fn sanitized(p: &[glam::Vec3]) -> Vec<glam::Vec3> {
    p.iter()
        .map(|v| if v.is_finite() { *v } else { glam::Vec3::ZERO })
        .collect()
}

fn table_rows(r: &Report) -> Vec<(String, String)> {
    let mut rows = Vec::new();
    let verdict = match r.verdict {
        Some(v) if v.passes() => "PASS: no difference detected".to_string(),
        Some(_) => "FAIL: the images differ".to_string(),
        None => "not tested: neither image has a variance".to_string(),
    };
    rows.push(("verdict".into(), verdict));
    rows.push((
        "images".into(),
        format!(
            "{} vs {} ({}x{})",
            r.labels[0], r.labels[1], r.a.width, r.a.height
        ),
    ));
    let spp = |s: Option<u32>| s.map_or("unknown".into(), |s| s.to_string());
    rows.push((
        "samples per pixel".into(),
        format!("{}, {}", spp(r.a.spp), spp(r.b.spp)),
    ));
    if let Some(v) = r.verdict {
        let px = &v.pixels;
        rows.push(("method".into(), v.method.describe().into()));
        rows.push((
            "per-pixel tests".into(),
            px.describe(
                v.settings
                    .family_alpha(crate::compare::image::Family::Pixels),
                v.settings.max_skewness,
            ),
        ));
        let ag = &v.aggregate;
        let sums: Vec<String> = ag
            .image
            .iter()
            .zip(["R", "G", "B"])
            .map(|(t, c)| format!("{c}: {:+.3} (p {:.2e})", t.statistic, t.p))
            .collect();
        rows.push((
            "image sum".into(),
            format!(
                "{}; reject beyond about ±{:.2} (Šidák over 3): {}",
                sums.join(", "),
                stats::normal_two_sided_bound(ag.image_alpha),
                if ag.image_passes() { "pass" } else { "FAIL" }
            ),
        ));
        let worst = ag.worst_tile().map_or(String::new(), |t| {
            format!(
                "; worst ({}..{}, {}..{}) {}: {:+.3} (p {:.2e})",
                t.x0,
                t.x1,
                t.y0,
                t.y1,
                ["R", "G", "B"][t.channel],
                t.statistic,
                t.p
            )
        });
        rows.push((
            format!("{0}x{0} tile sums", ag.tile_size),
            format!(
                "{} of {} fail at Šidák level {:.2e}{worst}",
                ag.failing_tiles().count(),
                ag.tiles.len(),
                ag.tile_alpha
            ),
        ));
        let floor = format!(
            "{:e} per sample (Mitsuba 3's clamp)",
            v.settings.variance_floor
        );
        rows.push((
            "variance floor".into(),
            if r.a.spp.is_some() && r.b.spp.is_some() {
                floor
            } else {
                format!(
                    "{floor} where the sample count is known; an image without one: its \
                     variance of the mean as given, floored only at f32 resolution (8 ulps of the mean)"
                )
            },
        ));
    }
    let m = r.metrics;
    rows.push(("RMSE".into(), format!("{:.5e}", m.rmse)));
    rows.push(("relMSE (ε = 0.01)".into(), format!("{:.5e}", m.relmse)));
    rows.push(("FLIP mean".into(), format!("{:.5}", m.flip_mean)));
    rows.push((
        "NaN/Inf values".into(),
        format!("{}, {}", m.nonfinite_values[0], m.nonfinite_values[1]),
    ));
    rows.push((
        "rejected NaN/Inf samples".into(),
        format!("{}, {}", m.nonfinite_samples[0], m.nonfinite_samples[1]),
    ));
    rows.extend(r.notes.iter().cloned());
    rows
}

/// The report as one HTML document.
pub fn render_html(r: &Report) -> Result<String> {
    let figs = figures(r)?;
    let display = (r.a.width * 8).clamp(192, 384);
    let mut o = String::new();
    let pass = r.verdict.map(Verdict::passes);
    let banner = match pass {
        Some(true) => ("#1b7f3b", "PASS"),
        Some(false) => ("#b3261e", "FAIL"),
        None => ("#6b6b6b", "NOT TESTED"),
    };
    let _ = write!(
        o,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{title}</title>\n<style>\n\
         body {{ font-family: system-ui, sans-serif; margin: 1.5em; color: #222; }}\n\
         .banner {{ display: inline-block; padding: 0.3em 0.8em; color: white; background: {colour}; font-weight: bold; border-radius: 4px; }}\n\
         .grid {{ display: flex; flex-wrap: wrap; gap: 1em; margin: 1em 0; }}\n\
         figure {{ margin: 0; width: {display}px; }}\n\
         figure img {{ width: {display}px; image-rendering: pixelated; border: 1px solid #ccc; }}\n\
         figcaption {{ font-size: 0.8em; }}\n\
         table {{ border-collapse: collapse; }} td {{ border: 1px solid #ddd; padding: 0.25em 0.6em; vertical-align: top; }}\n\
         td:first-child {{ font-weight: bold; white-space: nowrap; }}\n\
         </style></head><body>\n<h1>{title}</h1>\n<p><span class=\"banner\">{word}</span></p>\n<div class=\"grid\">\n",
        title = esc(&r.title),
        colour = banner.0,
        word = banner.1,
    );
    for (caption, uri) in &figs {
        let _ = writeln!(
            o,
            "<figure><img src=\"{uri}\" alt=\"{c}\"><figcaption>{c}</figcaption></figure>",
            c = esc(caption)
        );
    }
    o.push_str("</div>\n<table>\n");
    for (k, v) in table_rows(r) {
        let _ = writeln!(o, "<tr><td>{}</td><td>{}</td></tr>", esc(&k), esc(&v));
    }
    o.push_str("</table>\n</body></html>\n");
    Ok(o)
}

/// Writes the report to `path` (all or nothing).
pub fn write_html(path: &Path, r: &Report) -> Result<()> {
    let html = render_html(r)?;
    image_io::write_atomic(path, |f| {
        use std::io::Write;
        f.write_all(html.as_bytes())?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc_4648_vectors() {
        for (input, out) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(input.as_bytes()), out);
        }
        assert_eq!(base64(&[0xff, 0xfe, 0xfd]), "//79");
    }

    #[test]
    fn colours_span_their_ramps() {
        assert_eq!(lerp_colour(&HEAT, 0.0), [0, 0, 0]);
        assert_eq!(lerp_colour(&HEAT, 1.0), [255, 255, 255]);
        assert_eq!(lerp_colour(&DIVERGING, 0.5), [255, 255, 255]);
        assert_eq!(lerp_colour(&HEAT, f32::NAN), [255, 255, 255]);
    }
}
