//! Regenerates the generated fixture files under fixtures/ (run through
//! `cargo xtask fixtures`): the bumpy-sphere glTF mesh, the UV-grid PNG
//! texture and the procedural sky HDR environment map. Every file is a
//! pure function of the code here, so the fixtures need no licence.

use glam::Vec3;
use std::path::Path;

fn main() -> anyhow::Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    // 20 · 4^5 = 20480 triangles, closed (the watertightness suite uses it).
    let mesh = reference::procedural::bumpy_sphere(5, 0.08, 6.0);
    reference::procedural::write_glb(&root.join("meshes/bumpy_sphere.glb"), &mesh)?;
    uv_grid(&root.join("textures/uv_grid.png"))?;
    sky_hdr(&root.join("textures/sky.hdr"))?;
    println!("fixtures written under {}", root.display());
    Ok(())
}

/// A 256x256 UV test grid: 8x8 coloured cells with dark lines, a white
/// marker in the bottom-left cell so orientation errors show.
fn uv_grid(path: &Path) -> anyhow::Result<()> {
    let n = 256u32;
    let img = image::RgbImage::from_fn(n, n, |x, y| {
        let (cx, cy) = (x / 32, (n - 1 - y) / 32); // cy counts from the bottom
        if x % 32 == 0 || y % 32 == 0 {
            return image::Rgb([20, 20, 20]);
        }
        if cx == 0 && cy == 0 {
            return image::Rgb([255, 255, 255]);
        }
        let r = (40 + cx * 30) as u8;
        let g = (40 + cy * 30) as u8;
        let b = if (cx + cy) % 2 == 0 { 200 } else { 60 };
        image::Rgb([r, g, b])
    });
    img.save(path)?;
    Ok(())
}

/// A 512x256 equirectangular sky (see reference::background::equirect_uv):
/// a blue gradient, a small bright sun, and a dim brown ground.
fn sky_hdr(path: &Path) -> anyhow::Result<()> {
    let (w, h) = (512u32, 256u32);
    let sun = Vec3::new(0.4, 0.6, -0.7).normalize();
    let img = image::Rgb32FImage::from_fn(w, h, |x, y| {
        let u = (x as f32 + 0.5) / w as f32;
        let v = 1.0 - (y as f32 + 0.5) / h as f32;
        let phi = (u - 0.5) * 2.0 * std::f32::consts::PI;
        let theta = (1.0 - v) * std::f32::consts::PI;
        let d = Vec3::new(
            theta.sin() * phi.sin(),
            theta.cos(),
            -theta.sin() * phi.cos(),
        );
        let c = if d.y < 0.0 {
            Vec3::new(0.25, 0.2, 0.15)
        } else {
            Vec3::new(0.9, 0.95, 1.0).lerp(Vec3::new(0.25, 0.45, 0.9), d.y.sqrt())
        };
        let c = if d.dot(sun) > 0.995 {
            Vec3::splat(60.0)
        } else {
            c
        };
        image::Rgb(c.to_array())
    });
    image::DynamicImage::ImageRgb32F(img).save(path)?;
    Ok(())
}
