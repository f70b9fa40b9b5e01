//! Regenerates the generated fixture files under fixtures/ (run through
//! `cargo xtask fixtures`): the bumpy-sphere glTF mesh, the glTF of the
//! glTF-materials scene, the UV-grid PNG texture and the procedural sky
//! HDR environment map. Every file is a pure function of the code here, so
//! the fixtures need no licence. Each is written whole or not at all (a
//! temporary file renamed into place), so an interrupted run leaves the
//! fixture it was replacing.

use glam::Vec3;
use std::path::Path;

fn main() -> anyhow::Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    // 20 · 4^5 = 20480 triangles, closed (the watertightness suite uses it).
    let mesh = reference::procedural::bumpy_sphere(5, 0.08, 6.0);
    reference::procedural::write_glb(&root.join("meshes/bumpy_sphere.glb"), &mesh)?;
    write(&root.join("meshes/gltf-materials.glb"), &gltf_materials()?)?;
    uv_grid(&root.join("textures/uv_grid.png"))?;
    sky_hdr(&root.join("textures/sky.hdr"))?;
    println!("fixtures written under {}", root.display());
    Ok(())
}

/// Writes `path` atomically (`twintrace::image_io::write_atomic`).
fn write(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    twintrace::image_io::write_atomic(path, |f| Ok(std::io::Write::write_all(f, bytes)?))
}

/// `image` encoded as `format`, written atomically.
fn save(path: &Path, image: image::DynamicImage, format: image::ImageFormat) -> anyhow::Result<()> {
    let mut bytes = Vec::new();
    image.write_to(&mut std::io::Cursor::new(&mut bytes), format)?;
    write(path, &bytes)
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
    save(
        path,
        image::DynamicImage::ImageRgb8(img),
        image::ImageFormat::Png,
    )
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
    save(
        path,
        image::DynamicImage::ImageRgb32F(img),
        image::ImageFormat::Hdr,
    )
}

/// The glTF of fixtures/scenes/gltf-materials.json: a sampled backdrop
/// (below) and two UV spheres
/// (radius 1, 32 segments, 16 rings; POSITION, NORMAL, TEXCOORD_0), each a
/// node with its own material, as other tools write them:
/// - left: base colour factor (0.9, 0.6, 0.3), metallic and roughness
///   factors 1, scaled per point by an 8x8 `metallicRoughnessTexture`
///   (linear data): green (roughness) rises from 0.1 to 0.9 across u, blue
///   (metallic) is 1 in the image's top half and 0 in its bottom half; and
///   by vertex colours (COLOR_0, normalized bytes) that shade from
///   (1, 0.4, 1) at the bottom to (1, 1, 0.3) at the top;
/// - right: `KHR_materials_transmission` 1, `KHR_materials_ior` 1.5,
///   `KHR_materials_volume` (thickness 1, attenuation colour (0.9, 0.6,
///   0.3) at distance 1): smooth glass with Beer-Lambert absorption;
///
/// the backdrop is coated (`KHR_materials_clearcoat`, factor 1 times its
/// tiles' red channel, roughness 0.15);
///
/// and two panels in front: a lattice between the spheres, `alphaMode`
/// MASK (cutoff 0.5) over an 8x8 RGBA base colour image whose alpha is 0
/// on every third diagonal (bilinear: the holes' edges lie where the
/// filtered alpha crosses the cutoff), and a pane before the left sphere,
/// BLEND, alpha 0.7 times a vertex alpha (COLOR_0, floats) from 1 at the
/// bottom to 0.2 at the top.
fn gltf_materials() -> anyhow::Result<Vec<u8>> {
    use serde_json::json;
    const SEGMENTS: u32 = 32;
    const RINGS: u32 = 16;
    let (mut positions, mut uvs, mut indices) = (Vec::new(), Vec::new(), Vec::<u16>::new());
    for r in 0..=RINGS {
        let theta = std::f32::consts::PI * r as f32 / RINGS as f32;
        for s in 0..=SEGMENTS {
            let phi = 2.0 * std::f32::consts::PI * s as f32 / SEGMENTS as f32;
            positions.push([
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ]);
            // glTF's texture origin is the top-left corner: v = 0 on top.
            uvs.push([s as f32 / SEGMENTS as f32, r as f32 / RINGS as f32]);
        }
    }
    let row = (SEGMENTS + 1) as u16;
    for r in 0..RINGS as u16 {
        for s in 0..SEGMENTS as u16 {
            let (a, b) = (r * row + s, r * row + s + 1);
            let (c, d) = (a + row, b + row);
            // Counter-clockwise seen from outside; no slivers at the poles.
            if r != 0 {
                indices.extend([a, b, c]);
            }
            if r != RINGS as u16 - 1 {
                indices.extend([b, d, c]);
            }
        }
    }
    let mut png = Vec::new();
    let image = image::RgbImage::from_fn(8, 8, |x, y| {
        let rough = (255.0 * (0.1 + 0.8 * x as f32 / 7.0)).round() as u8;
        image::Rgb([0, rough, if y < 4 { 255 } else { 0 }])
    });
    image.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;

    let mut bin = Vec::new();
    let mut views = Vec::new();
    let mut add_view = |data: &[u8], target: Option<u32>| {
        bin.resize(bin.len().next_multiple_of(4), 0);
        let mut view = json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": data.len() });
        if let Some(t) = target {
            view["target"] = t.into();
        }
        bin.extend_from_slice(data);
        views.push(view);
        views.len() - 1
    };
    let floats =
        |v: &[[f32; 3]]| -> Vec<u8> { v.iter().flatten().flat_map(|f| f.to_le_bytes()).collect() };
    let positions_view = add_view(&floats(&positions), Some(34962));
    let colors: Vec<u8> = positions
        .iter()
        .flat_map(|p| {
            let t = (p[1] + 1.0) / 2.0;
            [1.0, 0.4 + 0.6 * t, 1.0 - 0.7 * t, 1.0].map(|c: f32| (255.0 * c).round() as u8)
        })
        .collect();
    let colors_view = add_view(&colors, Some(34962));
    let uv_bytes: Vec<u8> = uvs
        .iter()
        .flatten()
        .flat_map(|f: &f32| f.to_le_bytes())
        .collect();
    let uv_view = add_view(&uv_bytes, Some(34962));
    let index_bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
    let index_view = add_view(&index_bytes, Some(34963));
    let image_view = add_view(&png, None);
    // The backdrop: a 5.2 x 2.6 panel facing +z behind the spheres, uv 0..1
    // over it (v = 0 along its top edge), with a 4x4 base colour image of
    // distinct texels read through a clamp / mirror / nearest sampler and a
    // texture transform that carries uv well outside [0, 1]; and a normal
    // map, tiled 3x2 by its own transform, over the second coordinate set
    // (u mirrored).
    let panel: [[f32; 3]; 4] = [
        [-2.6, 0.0, -1.6],
        [2.6, 0.0, -1.6],
        [2.6, 2.6, -1.6],
        [-2.6, 2.6, -1.6],
    ];
    let panel_view = add_view(&floats(&panel), Some(34962));
    let panel_normal_view = add_view(&floats(&[[0.0, 0.0, 1.0]; 4]), Some(34962));
    let panel_uvs: Vec<u8> = [[0.0f32, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]]
        .iter()
        .flatten()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    let panel_uv_view = add_view(&panel_uvs, Some(34962));
    // The second set: u mirrored, read by the normal map.
    let panel_uvs1: Vec<u8> = [[1.0f32, 1.0], [0.0, 1.0], [0.0, 0.0], [1.0, 0.0]]
        .iter()
        .flatten()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    let panel_uv1_view = add_view(&panel_uvs1, Some(34962));
    // An 8x8 tangent-space normal map (linear data) in four quadrants,
    // each tilted 50 degrees: toward +tangent (top left), -tangent (top
    // right), +bitangent (bottom left), -bitangent (bottom right).
    let mut normals_png = Vec::new();
    let (sin, cos) = 50f32.to_radians().sin_cos();
    image::RgbImage::from_fn(8, 8, |x, y| {
        let n = match (x < 4, y < 4) {
            (true, true) => [sin, 0.0, cos],
            (false, true) => [-sin, 0.0, cos],
            (true, false) => [0.0, sin, cos],
            (false, false) => [0.0, -sin, cos],
        };
        image::Rgb(n.map(|c| (255.0 * (c + 1.0) / 2.0).round() as u8))
    })
    .write_to(
        &mut std::io::Cursor::new(&mut normals_png),
        image::ImageFormat::Png,
    )?;
    let normals_view = add_view(&normals_png, None);
    let panel_index_view = add_view(
        &[0u16, 1, 2, 0, 2, 3]
            .iter()
            .flat_map(|i| i.to_le_bytes())
            .collect::<Vec<u8>>(),
        Some(34963),
    );
    let mut tiles = Vec::new();
    image::RgbImage::from_fn(4, 4, |x, y| {
        let k = (4 * y + x) as u8;
        image::Rgb([
            40 + 13 * k,
            230 - 12 * k,
            if (x + y) % 2 == 0 { 220 } else { 30 },
        ])
    })
    .write_to(
        &mut std::io::Cursor::new(&mut tiles),
        image::ImageFormat::Png,
    )?;
    let tiles_view = add_view(&tiles, None);
    // The MASK lattice and the BLEND pane (quads facing +z, uv 0..1 as the
    // backdrop's).
    let lattice: [[f32; 3]; 4] = [
        [-0.5, 0.2, 1.2],
        [0.5, 0.2, 1.2],
        [0.5, 1.4, 1.2],
        [-0.5, 1.4, 1.2],
    ];
    let lattice_view = add_view(&floats(&lattice), Some(34962));
    let pane: [[f32; 3]; 4] = [
        [-2.3, 0.1, 1.4],
        [-1.3, 0.1, 1.4],
        [-1.3, 0.8, 1.4],
        [-2.3, 0.8, 1.4],
    ];
    let pane_view = add_view(&floats(&pane), Some(34962));
    let pane_colors: Vec<u8> = [1.0f32, 1.0, 0.2, 0.2]
        .iter()
        .flat_map(|&a| [0.3f32, 0.5, 0.9, a])
        .flat_map(f32::to_le_bytes)
        .collect();
    let pane_colors_view = add_view(&pane_colors, Some(34962));
    let mut lattice_png = Vec::new();
    image::RgbaImage::from_fn(8, 8, |x, y| {
        let open = (x + y) % 3 == 0;
        image::Rgba([200, 70, 60, if open { 0 } else { 255 }])
    })
    .write_to(
        &mut std::io::Cursor::new(&mut lattice_png),
        image::ImageFormat::Png,
    )?;
    let lattice_image_view = add_view(&lattice_png, None);
    bin.resize(bin.len().next_multiple_of(4), 0);
    let n = positions.len();
    // A unit sphere's normals are its positions: one accessor for both.
    let accessors = json!([
        { "bufferView": positions_view, "componentType": 5126, "count": n, "type": "VEC3", "min": [-1, -1, -1], "max": [1, 1, 1] },
        { "bufferView": uv_view, "componentType": 5126, "count": n, "type": "VEC2" },
        { "bufferView": index_view, "componentType": 5123, "count": indices.len(), "type": "SCALAR" },
        { "bufferView": panel_view, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-2.6, 0.0, -1.6], "max": [2.6, 2.6, -1.6] },
        { "bufferView": panel_normal_view, "componentType": 5126, "count": 4, "type": "VEC3" },
        { "bufferView": panel_uv_view, "componentType": 5126, "count": 4, "type": "VEC2" },
        { "bufferView": panel_index_view, "componentType": 5123, "count": 6, "type": "SCALAR" },
        { "bufferView": colors_view, "componentType": 5121, "normalized": true, "count": n, "type": "VEC4" },
        { "bufferView": panel_uv1_view, "componentType": 5126, "count": 4, "type": "VEC2" },
        { "bufferView": lattice_view, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-0.5, 0.2, 1.2], "max": [0.5, 1.4, 1.2] },
        { "bufferView": pane_view, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-2.3, 0.1, 1.4], "max": [-1.3, 0.8, 1.4] },
        { "bufferView": pane_colors_view, "componentType": 5126, "count": 4, "type": "VEC4" },
    ]);
    let sphere = json!({ "POSITION": 0, "NORMAL": 0, "TEXCOORD_0": 1 });
    let mut coloured = sphere.clone();
    coloured["COLOR_0"] = 7.into();
    let document = json!({
        "asset": { "version": "2.0", "generator": "twintrace examples/gen_fixtures.rs" },
        "extensionsUsed": ["KHR_materials_clearcoat", "KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume", "KHR_texture_transform"],
        "scene": 0,
        "scenes": [{ "nodes": [0, 1, 2, 3, 4] }],
        "nodes": [
            { "name": "metallic-roughness", "mesh": 0, "translation": [-1.1, 1.0, 0.0] },
            { "name": "glass", "mesh": 1, "translation": [1.1, 1.0, 0.0] },
            { "name": "sampled backdrop", "mesh": 2 },
            { "name": "masked lattice", "mesh": 3 },
            { "name": "blended pane", "mesh": 4 },
        ],
        "meshes": [
            { "primitives": [{ "attributes": coloured, "indices": 2, "material": 0 }] },
            { "primitives": [{ "attributes": sphere, "indices": 2, "material": 1 }] },
            { "primitives": [{ "attributes": { "POSITION": 3, "NORMAL": 4, "TEXCOORD_0": 5, "TEXCOORD_1": 8 }, "indices": 6, "material": 2 }] },
            { "primitives": [{ "attributes": { "POSITION": 9, "NORMAL": 4, "TEXCOORD_0": 5 }, "indices": 6, "material": 3 }] },
            { "primitives": [{ "attributes": { "POSITION": 10, "NORMAL": 4, "COLOR_0": 11 }, "indices": 6, "material": 4 }] },
        ],
        "materials": [
            {
                "name": "textured metal-roughness",
                "pbrMetallicRoughness": {
                    "baseColorFactor": [0.9, 0.6, 0.3, 1.0],
                    "metallicFactor": 1.0,
                    "roughnessFactor": 1.0,
                    "metallicRoughnessTexture": { "index": 0 },
                },
            },
            {
                "name": "glass",
                "pbrMetallicRoughness": { "metallicFactor": 0.0, "roughnessFactor": 0.0 },
                "extensions": {
                    "KHR_materials_transmission": { "transmissionFactor": 1.0 },
                    "KHR_materials_ior": { "ior": 1.5 },
                    "KHR_materials_volume": { "thicknessFactor": 1.0, "attenuationDistance": 1.0, "attenuationColor": [0.9, 0.6, 0.3] },
                },
            },
            {
                "name": "sampled backdrop",
                "pbrMetallicRoughness": {
                    "baseColorTexture": {
                        "index": 1,
                        "extensions": { "KHR_texture_transform": { "offset": [-0.3, 0.2], "rotation": 0.3, "scale": [1.6, 2.2] } },
                    },
                    "metallicFactor": 0.0,
                    "roughnessFactor": 1.0,
                },
                // A clear coat whose weight follows the tiles' red channel
                // (the image read a second time, as linear data).
                "extensions": {
                    "KHR_materials_clearcoat": { "clearcoatFactor": 1.0, "clearcoatTexture": { "index": 1 }, "clearcoatRoughnessFactor": 0.15 },
                },
                // No TANGENT: the importer generates MikkTSpace tangents
                // (from the second set, mirrored: w = -1).
                "normalTexture": {
                    "index": 2,
                    "texCoord": 1,
                    "scale": 0.8,
                    "extensions": { "KHR_texture_transform": { "scale": [3.0, 2.0] } },
                },
            },
            {
                "name": "masked lattice",
                "pbrMetallicRoughness": { "baseColorTexture": { "index": 3 }, "metallicFactor": 0.0, "roughnessFactor": 0.6 },
                "alphaMode": "MASK",
                "alphaCutoff": 0.5,
            },
            {
                "name": "blended pane",
                "pbrMetallicRoughness": { "baseColorFactor": [1.0, 1.0, 1.0, 0.7], "metallicFactor": 0.0, "roughnessFactor": 0.3 },
                "alphaMode": "BLEND",
            },
        ],
        "samplers": [{ "wrapS": 33071, "wrapT": 33648, "magFilter": 9728 }],
        "textures": [{ "source": 0 }, { "source": 1, "sampler": 0 }, { "source": 2 }, { "source": 3 }],
        "images": [
            { "bufferView": image_view, "mimeType": "image/png" },
            { "bufferView": tiles_view, "mimeType": "image/png" },
            { "bufferView": normals_view, "mimeType": "image/png" },
            { "bufferView": lattice_image_view, "mimeType": "image/png" },
        ],
        "buffers": [{ "byteLength": bin.len() }],
        "bufferViews": views,
        "accessors": accessors,
    });
    Ok(reference::procedural::glb_container(&document, bin)?)
}
