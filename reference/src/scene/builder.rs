//! Building a scene: every parameter checked, then the BVH built.

use super::leaf::{batched, primitive_bounds};
use super::{primitive_tag, Primitive, RenderSettings, Scene, Transform};
use crate::background::Background;
use crate::bvh::Bvh;
use crate::camera::CameraSettings;
use crate::error::SceneError;
use crate::geometry::Aabb;
use crate::material::{Alpha, AlphaMode, Material};
use crate::shapes::{
    MeshData, Quad, Sphere, Triangle, TRIANGLE_HAS_ALPHA, TRIANGLE_HAS_COLORS,
    TRIANGLE_HAS_NORMALS, TRIANGLE_HAS_TANGENTS, TRIANGLE_HAS_UV1, TRIANGLE_HAS_UVS,
};
use crate::texture::{ImageData, Texture};
use glam::{Mat3, Vec2, Vec3, Vec4};
use std::path::PathBuf;

/// An indexed triangle mesh before placement.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshInput {
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    /// Three indices per triangle.
    pub indices: Vec<u32>,
    /// Linear RGBA vertex colours (they scale the GGX base colour).
    pub colors: Option<Vec<Vec4>>,
    /// Tangents in the mesh's space (`MeshData::tangents`), for normal maps.
    pub tangents: Option<Vec<Vec4>>,
    /// A second set of texture coordinates (v up, as `uvs`).
    pub uvs1: Option<Vec<Vec2>>,
}

/// Collects a scene, checks it, and builds its BVH.
#[derive(Clone, Debug, Default)]
pub struct SceneBuilder {
    pub camera: CameraSettings,
    pub render: RenderSettings,
    pub background: Option<Background>,
    /// What the loaders ignored and the user should hear of (one line
    /// each), kept with the scene ([`Scene::warnings`]).
    pub warnings: Vec<String>,
    /// The files the loaders read to make the scene (the scene file, its
    /// meshes, glTF documents and buffers, images), as the loaders
    /// named them; kept with the scene ([`Scene::sources`]).
    pub sources: Vec<PathBuf>,
    spheres: Vec<Sphere>,
    quads: Vec<Quad>,
    triangles: Vec<Triangle>,
    mesh: MeshData,
    materials: Vec<Material>,
    /// By material: its coverage ([`SceneBuilder::set_alpha`]); shorter
    /// than `materials` until the build.
    alphas: Vec<Option<Alpha>>,
    textures: Vec<Texture>,
    images: Vec<ImageData>,
    primitives: Vec<Primitive>,
}

fn check_finite_vec(field: &str, v: Vec3) -> Result<(), SceneError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(SceneError::invalid(field, format!("{v} is not finite")))
    }
}

fn check_colour(field: &str, c: Vec3) -> Result<(), SceneError> {
    check_finite_vec(field, c)?;
    if c.min_element() < 0.0 {
        return Err(SceneError::invalid(
            field,
            format!("colour {c} has a negative component"),
        ));
    }
    Ok(())
}

/// Appends a mesh's `n` values of an optional vertex attribute to the
/// scene's array, which stays empty until some mesh has the attribute and
/// from then on has one entry per vertex (`fill` where a mesh had none).
fn push_attribute<T: Copy>(
    scene: &mut Vec<T>,
    base: u32,
    n: usize,
    fill: T,
    values: &Option<Vec<T>>,
    place: impl Fn(T) -> T,
) {
    match values {
        Some(values) => {
            scene.resize(base as usize, fill);
            scene.extend(values.iter().map(|&v| place(v)));
        }
        None if !scene.is_empty() => scene.extend(std::iter::repeat_n(fill, n)),
        None => {}
    }
}

/// A texture's values, and its references: to `images` images, and for a
/// checker to two of the `earlier` textures, neither a checker itself.
fn check_texture(texture: &Texture, earlier: &[Texture], images: usize) -> Result<(), SceneError> {
    match *texture {
        Texture::Constant(c) => check_colour("texture", c)?,
        Texture::Checker { scale, even, odd } => {
            if !scale.is_finite() {
                return Err(SceneError::invalid(
                    "texture.scale",
                    format!("{scale} is not finite"),
                ));
            }
            for (name, id) in [("even", even), ("odd", odd)] {
                match earlier.get(id as usize) {
                    None => {
                        return Err(SceneError::invalid(
                            &format!("texture.{name}"),
                            format!("texture index {id} does not exist"),
                        ))
                    }
                    Some(Texture::Checker { .. }) => {
                        return Err(SceneError::invalid(
                            &format!("texture.{name}"),
                            "a checker cannot nest another checker".into(),
                        ))
                    }
                    Some(_) => {}
                }
            }
        }
        Texture::Image {
            image,
            factor,
            sampler,
        } => {
            check_colour("texture.factor", factor)?;
            if let Some(t) = sampler.transform {
                if t.iter().any(|v| !v.is_finite()) {
                    return Err(SceneError::invalid(
                        "texture.transform",
                        format!("{t:?} must be finite"),
                    ));
                }
            }
            if sampler.tex_coord > 1 {
                return Err(SceneError::invalid(
                    "texture.tex_coord",
                    format!(
                        "coordinate set {} does not exist (0 or 1)",
                        sampler.tex_coord
                    ),
                ));
            }
            if image as usize >= images {
                return Err(SceneError::invalid(
                    "texture.image",
                    format!("image index {image} does not exist"),
                ));
            }
        }
    }
    Ok(())
}

/// A coverage's texture reference and cutoff.
pub(super) fn check_alpha(alpha: &Alpha, textures: usize) -> Result<(), SceneError> {
    if alpha.texture as usize >= textures {
        return Err(SceneError::invalid(
            "alpha.texture",
            format!("texture index {} does not exist", alpha.texture),
        ));
    }
    if let AlphaMode::Mask { cutoff } = alpha.mode {
        if !cutoff.is_finite() {
            return Err(SceneError::invalid(
                "alpha.cutoff",
                format!("{cutoff} is not finite"),
            ));
        }
    }
    Ok(())
}

/// A material's parameters, and its references to `textures` textures.
fn check_material(material: &Material, textures: usize) -> Result<(), SceneError> {
    let tex_ok = |field: &str, id: u32| {
        if (id as usize) < textures {
            Ok(())
        } else {
            Err(SceneError::invalid(
                field,
                format!("texture index {id} does not exist"),
            ))
        }
    };
    match *material {
        Material::Lambertian { albedo } => tex_ok("albedo", albedo)?,
        Material::Metal { albedo, fuzz } => {
            tex_ok("albedo", albedo)?;
            if !(0.0..=1.0).contains(&fuzz) {
                return Err(SceneError::invalid(
                    "fuzz",
                    format!("{fuzz} is outside [0, 1]"),
                ));
            }
        }
        Material::Dielectric { ior, absorption } => {
            if !(ior.is_finite() && ior > 0.0) {
                return Err(SceneError::invalid(
                    "ior",
                    format!("{ior} must be a positive finite number"),
                ));
            }
            check_colour("absorption", absorption)?;
        }
        Material::DiffuseLight { emission } => tex_ok("emission", emission)?,
        Material::Ggx {
            base_color,
            metallic,
            roughness,
            metallic_roughness,
            normal_map,
            clearcoat,
        } => {
            tex_ok("base_color", base_color)?;
            if let Some(coat) = clearcoat {
                for (name, t) in [
                    ("clearcoat.texture", coat.texture),
                    ("clearcoat.roughness_texture", coat.roughness_texture),
                ] {
                    if let Some(t) = t {
                        tex_ok(name, t)?;
                    }
                }
                for (name, v) in [
                    ("clearcoat", coat.factor),
                    ("clearcoat_roughness", coat.roughness),
                ] {
                    if !(0.0..=1.0).contains(&v) {
                        return Err(SceneError::invalid(name, format!("{v} is outside [0, 1]")));
                    }
                }
            }
            if let Some(t) = metallic_roughness {
                tex_ok("metallic_roughness", t)?;
            }
            if let Some(map) = normal_map {
                tex_ok("normal_map", map.texture)?;
                if !map.scale.is_finite() {
                    return Err(SceneError::invalid(
                        "normal_map.scale",
                        format!("{} is not finite", map.scale),
                    ));
                }
            }
            if !(0.0..=1.0).contains(&metallic) {
                return Err(SceneError::invalid(
                    "metallic",
                    format!("{metallic} is outside [0, 1]"),
                ));
            }
            if !(0.0..=1.0).contains(&roughness) {
                return Err(SceneError::invalid(
                    "roughness",
                    format!("{roughness} is outside [0, 1]"),
                ));
            }
        }
    }
    Ok(())
}

/// The camera, the render settings and the background (which may name one
/// of `images` images).
fn check_view(
    camera: &CameraSettings,
    render: &RenderSettings,
    background: &Background,
    images: usize,
) -> Result<(), SceneError> {
    render.validate()?;
    camera.validate()?;
    match *background {
        Background::Solid(col) => check_colour("background.color", col)?,
        Background::Sky { horizon, zenith } => {
            check_colour("background.horizon", horizon)?;
            check_colour("background.zenith", zenith)?;
        }
        Background::Envmap {
            image,
            intensity,
            rotate_y,
        } => {
            if image as usize >= images {
                return Err(SceneError::invalid(
                    "background.path",
                    "envmap image missing".into(),
                ));
            }
            if !(intensity.is_finite() && intensity >= 0.0 && rotate_y.is_finite()) {
                return Err(SceneError::invalid(
                    "background.intensity",
                    format!("intensity {intensity} / rotate_y {rotate_y} must be finite, intensity non-negative"),
                ));
            }
        }
    }
    Ok(())
}

impl SceneBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn add_image(&mut self, image: ImageData) -> u32 {
        self.images.push(image);
        self.images.len() as u32 - 1
    }

    /// Adds a texture after checking its references and values.
    pub fn add_texture(&mut self, texture: Texture) -> Result<u32, SceneError> {
        check_texture(&texture, &self.textures, self.images.len())?;
        self.textures.push(texture);
        Ok(self.textures.len() as u32 - 1)
    }

    /// Shorthand for a constant texture.
    pub fn constant(&mut self, c: Vec3) -> Result<u32, SceneError> {
        self.add_texture(Texture::Constant(c))
    }

    /// Adds a material after checking its parameters.
    pub fn add_material(&mut self, material: Material) -> Result<u32, SceneError> {
        check_material(&material, self.textures.len())?;
        self.materials.push(material);
        Ok(self.materials.len() as u32 - 1)
    }

    /// Gives material `material` a coverage: the triangles that use it are
    /// hit only where it covers the point ([`Scene::alpha_covers`]). Only
    /// triangles can have one (the build refuses a sphere or quad whose
    /// material has).
    pub fn set_alpha(&mut self, material: u32, alpha: Alpha) -> Result<(), SceneError> {
        self.check_material(material)?;
        check_alpha(&alpha, self.textures.len())?;
        let m = material as usize;
        if self.alphas.len() <= m {
            self.alphas.resize(m + 1, None);
        }
        self.alphas[m] = Some(alpha);
        Ok(())
    }

    fn check_material(&self, material: u32) -> Result<(), SceneError> {
        if (material as usize) < self.materials.len() {
            Ok(())
        } else {
            Err(SceneError::invalid(
                "material",
                format!("material index {material} does not exist"),
            ))
        }
    }

    fn push_primitive(&mut self, tag: u32, index: usize) {
        self.primitives.push(Primitive {
            tag,
            index: index as u32,
        });
    }

    /// A sphere, placed by `transform` (which must be a similarity: a
    /// sphere under non-uniform scale is an ellipsoid, not a sphere).
    pub fn add_sphere(
        &mut self,
        center: Vec3,
        radius: f32,
        material: u32,
        transform: &Transform,
    ) -> Result<(), SceneError> {
        self.check_material(material)?;
        check_finite_vec("center", center)?;
        if !(radius.is_finite() && radius != 0.0) {
            return Err(SceneError::invalid(
                "radius",
                format!("{radius} must be a finite non-zero number"),
            ));
        }
        let scale = transform.uniform_scale().ok_or_else(|| {
            SceneError::invalid("transform", "a sphere accepts only uniform scale".into())
        })?;
        let s = Sphere {
            center: transform.point(center),
            radius: radius * scale,
            material,
        };
        check_finite_vec("transform", s.center)?;
        if !(s.radius.is_finite() && s.radius != 0.0) {
            return Err(SceneError::invalid(
                "transform",
                format!("the placed radius {} is degenerate", s.radius),
            ));
        }
        self.spheres.push(s);
        self.push_primitive(primitive_tag::SPHERE, self.spheres.len() - 1);
        Ok(())
    }

    /// A parallelogram `corner + s·u + t·v`, placed by `transform`.
    pub fn add_quad(
        &mut self,
        corner: Vec3,
        u: Vec3,
        v: Vec3,
        material: u32,
        transform: &Transform,
    ) -> Result<(), SceneError> {
        self.check_material(material)?;
        for (f, x) in [("corner", corner), ("u", u), ("v", v)] {
            check_finite_vec(f, x)?;
        }
        let q = Quad {
            corner: transform.point(corner),
            u: transform.vector(u),
            v: transform.vector(v),
            material,
        };
        let n = q.u.cross(q.v);
        if !(n.is_finite() && n.length_squared() > 0.0 && q.corner.is_finite()) {
            return Err(SceneError::invalid(
                "u/v",
                "the quad is degenerate (u and v are parallel or zero)".into(),
            ));
        }
        self.quads.push(q);
        self.push_primitive(primitive_tag::QUAD, self.quads.len() - 1);
        Ok(())
    }

    /// An axis-aligned box in its own frame (six quads, outward normals).
    pub fn add_box(
        &mut self,
        min: Vec3,
        max: Vec3,
        material: u32,
        transform: &Transform,
    ) -> Result<(), SceneError> {
        check_finite_vec("min", min)?;
        check_finite_vec("max", max)?;
        if !min.cmplt(max).all() {
            return Err(SceneError::invalid(
                "min/max",
                format!("min {min} must be below max {max} on every axis"),
            ));
        }
        let d = max - min;
        let (dx, dy, dz) = (
            Vec3::new(d.x, 0.0, 0.0),
            Vec3::new(0.0, d.y, 0.0),
            Vec3::new(0.0, 0.0, d.z),
        );
        // Each face: corner, u, v with u × v pointing out of the box.
        let faces = [
            (Vec3::new(min.x, min.y, max.z), dx, dy),  // front (+z)
            (Vec3::new(max.x, min.y, max.z), -dz, dy), // right (+x)
            (Vec3::new(max.x, min.y, min.z), -dx, dy), // back (-z)
            (Vec3::new(min.x, min.y, min.z), dz, dy),  // left (-x)
            (Vec3::new(min.x, max.y, max.z), dx, -dz), // top (+y)
            (Vec3::new(min.x, min.y, min.z), dx, dz),  // bottom (-y)
        ];
        let mirror = Mat3::from(transform.matrix.matrix3).determinant() < 0.0;
        for (corner, u, v) in faces {
            // A mirroring transform flips u × v; swap to keep normals outward.
            let (u, v, c) = if mirror {
                (v, u, corner)
            } else {
                (u, v, corner)
            };
            self.add_quad(c, u, v, material, transform)?;
        }
        Ok(())
    }

    /// An indexed triangle mesh placed by `transform`. Degenerate
    /// triangles are kept (they never report a hit); out-of-range indices
    /// and non-finite data are errors.
    pub fn add_mesh(
        &mut self,
        mesh: &MeshInput,
        material: u32,
        transform: &Transform,
    ) -> Result<(), SceneError> {
        self.check_material(material)?;
        let n = mesh.positions.len();
        if mesh.indices.len() % 3 != 0 {
            return Err(SceneError::invalid(
                "indices",
                format!("{} indices is not a multiple of 3", mesh.indices.len()),
            ));
        }
        if let Some(bad) = mesh.indices.iter().find(|&&i| i as usize >= n) {
            return Err(SceneError::invalid(
                "indices",
                format!("index {bad} is out of range for {n} vertices"),
            ));
        }
        for (name, len) in [
            ("normals", mesh.normals.as_ref().map(Vec::len)),
            ("uvs", mesh.uvs.as_ref().map(Vec::len)),
            ("colors", mesh.colors.as_ref().map(Vec::len)),
            ("tangents", mesh.tangents.as_ref().map(Vec::len)),
            ("uvs1", mesh.uvs1.as_ref().map(Vec::len)),
        ] {
            if let Some(len) = len.filter(|&l| l != n) {
                return Err(SceneError::invalid(
                    name,
                    format!("{len} entries for {n} vertices"),
                ));
            }
        }
        if mesh.indices.is_empty() {
            return Err(SceneError::invalid(
                "indices",
                "the mesh has no triangles".into(),
            ));
        }
        let base = self.mesh.positions.len() as u32;
        if (base as usize + n) > u32::MAX as usize / 2 {
            return Err(SceneError::invalid("positions", "too many vertices".into()));
        }
        // Everything is checked before the scene's arrays change, so a mesh
        // refused leaves the builder as it was.
        if let Some(colors) = &mesh.colors {
            if let Some((i, c)) = colors
                .iter()
                .enumerate()
                .find(|(_, c)| !c.is_finite() || c.min_element() < 0.0)
            {
                return Err(SceneError::invalid(
                    "colors",
                    format!("vertex {i}'s colour {c} is negative or not finite"),
                ));
            }
        }
        let placed: Vec<Vec3> = mesh.positions.iter().map(|&p| transform.point(p)).collect();
        if let Some(i) = placed.iter().position(|p| !p.is_finite()) {
            return Err(SceneError::invalid(
                "positions",
                format!(
                    "vertex {i} ({}) is not finite once placed",
                    mesh.positions[i]
                ),
            ));
        }
        let nm = transform.normal_matrix();
        for (i, wp) in placed.into_iter().enumerate() {
            self.mesh.positions.push(wp);
            let wn = mesh
                .normals
                .as_ref()
                .map_or(Vec3::ZERO, |ns| (nm * ns[i]).normalize_or_zero());
            self.mesh
                .normals
                .push(if wn.is_finite() { wn } else { Vec3::ZERO });
            let uv = mesh.uvs.as_ref().map_or(Vec2::ZERO, |uvs| uvs[i]);
            self.mesh
                .uvs
                .push(if uv.is_finite() { uv } else { Vec2::ZERO });
        }
        // A mirroring placement turns the tangent frame's handedness.
        let mirrors = Mat3::from(transform.matrix.matrix3).determinant() < 0.0;
        let placed_tangent = |t: Vec4| {
            let xyz = transform.vector(t.truncate()).normalize_or_zero();
            let w = if (t.w < 0.0) != mirrors { -1.0 } else { 1.0 };
            if xyz.is_finite() && t.w.is_finite() {
                xyz.extend(w)
            } else {
                Vec4::ZERO
            }
        };
        push_attribute(
            &mut self.mesh.colors,
            base,
            n,
            Vec4::ONE,
            &mesh.colors,
            |c| c,
        );
        push_attribute(
            &mut self.mesh.tangents,
            base,
            n,
            Vec4::ZERO,
            &mesh.tangents,
            placed_tangent,
        );
        push_attribute(&mut self.mesh.uvs1, base, n, Vec2::ZERO, &mesh.uvs1, |uv| {
            if uv.is_finite() {
                uv
            } else {
                Vec2::ZERO
            }
        });
        let flags = [
            (mesh.normals.is_some(), TRIANGLE_HAS_NORMALS),
            (mesh.uvs.is_some(), TRIANGLE_HAS_UVS),
            (mesh.colors.is_some(), TRIANGLE_HAS_COLORS),
            (mesh.tangents.is_some(), TRIANGLE_HAS_TANGENTS),
            (mesh.uvs1.is_some(), TRIANGLE_HAS_UV1),
        ]
        .iter()
        .filter(|(has, _)| *has)
        .fold(0, |flags, (_, bit)| flags | bit);
        for tri in mesh.indices.chunks_exact(3) {
            self.triangles.push(Triangle {
                vertices: [base + tri[0], base + tri[1], base + tri[2]],
                material,
                flags,
            });
            self.push_primitive(primitive_tag::TRIANGLE, self.triangles.len() - 1);
        }
        Ok(())
    }

    pub fn material_count(&self) -> usize {
        self.materials.len()
    }

    pub fn texture_count(&self) -> usize {
        self.textures.len()
    }

    pub fn image(&self, id: u32) -> Option<&ImageData> {
        self.images.get(id as usize)
    }

    /// Checks the camera and settings and builds the BVH.
    pub fn build(self) -> Result<Scene, SceneError> {
        if self.primitives.is_empty() {
            return Err(SceneError::invalid(
                "objects",
                "the scene has no objects".into(),
            ));
        }
        let background = self.background.unwrap_or(Background::Solid(Vec3::ZERO));
        check_view(&self.camera, &self.render, &background, self.images.len())?;
        let mut alphas = self.alphas;
        alphas.resize(self.materials.len(), None);
        let has_alpha = |m: u32| alphas[m as usize].is_some();
        if let Some(m) = (self.spheres.iter().map(|s| s.material))
            .chain(self.quads.iter().map(|q| q.material))
            .find(|&m| has_alpha(m))
        {
            return Err(SceneError::invalid(
                "alpha",
                format!("material {m} has an alpha (coverage), which only triangles can have, but a sphere or quad uses it"),
            ));
        }
        let mut triangles = self.triangles;
        for tri in triangles.iter_mut().filter(|t| has_alpha(t.material)) {
            tri.flags |= TRIANGLE_HAS_ALPHA;
        }
        let bounds: Vec<Aabb> = self
            .primitives
            .iter()
            .map(|&p| primitive_bounds(p, &self.spheres, &self.quads, &triangles, &self.mesh))
            .collect();
        let batched: Vec<bool> = self.primitives.iter().map(|p| batched(p.tag)).collect();
        let (bvh, bvh_stats) = Bvh::build_batched(&bounds, &batched);
        let mut scene = Scene {
            camera_settings: self.camera,
            render: self.render,
            background,
            spheres: self.spheres,
            quads: self.quads,
            triangles,
            mesh: self.mesh,
            materials: self.materials,
            alphas,
            textures: self.textures,
            images: self.images,
            primitives: self.primitives,
            bvh: Bvh::default(),
            bvh_stats,
            leaf_prims: Vec::new(),
            leaf_bounds: Vec::new(),
            leaf_blocks: Vec::new(),
            quad_blocks: Vec::new(),
            warnings: self.warnings,
            sources: {
                let mut seen = std::collections::HashSet::new();
                self.sources
                    .into_iter()
                    .filter(|p| seen.insert(p.clone()))
                    .collect()
            },
        };
        scene.put_bvh(bvh);
        Ok(scene)
    }
}

/// What [`Scene::edited`] may change in a built scene: all but the geometry
/// (and so the BVH) and the images.
#[derive(Clone, Debug, PartialEq)]
pub struct Appearance {
    pub camera: CameraSettings,
    pub render: RenderSettings,
    pub background: Background,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
}

impl Scene {
    /// This scene with its camera, render settings, background, materials
    /// or textures changed by `edit`, checked again as [`SceneBuilder`]
    /// checks them: the materials' texture references against the edited
    /// textures, and the primitives' material references against the edited
    /// materials. The geometry and its BVH stay (a different shape is a
    /// different scene, built anew). For tests and tools that derive a
    /// variant of a loaded scene: a dimmed albedo, another camera.
    pub fn edited(mut self, edit: impl FnOnce(&mut Appearance)) -> Result<Scene, SceneError> {
        let mut look = Appearance {
            camera: self.camera_settings,
            render: self.render,
            background: self.background,
            materials: std::mem::take(&mut self.materials),
            textures: std::mem::take(&mut self.textures),
        };
        edit(&mut look);
        let images = self.images.len();
        check_view(&look.camera, &look.render, &look.background, images)?;
        for (i, texture) in look.textures.iter().enumerate() {
            check_texture(texture, &look.textures[..i], images)
                .map_err(|e| e.within(&format!("textures[{i}]")))?;
        }
        for (i, material) in look.materials.iter().enumerate() {
            check_material(material, look.textures.len())
                .map_err(|e| e.within(&format!("materials[{i}]")))?;
        }
        for alpha in self.alphas.iter().flatten() {
            check_alpha(alpha, look.textures.len()).map_err(|e| e.within("alphas"))?;
        }
        let used = (self.spheres.iter().map(|s| s.material))
            .chain(self.quads.iter().map(|q| q.material))
            .chain(self.triangles.iter().map(|t| t.material))
            .max();
        if let Some(m) = used.filter(|&m| m as usize >= look.materials.len()) {
            return Err(SceneError::invalid(
                "materials",
                format!(
                    "a primitive uses material {m}, but only {} remain",
                    look.materials.len()
                ),
            ));
        }
        self.camera_settings = look.camera;
        self.render = look.render;
        self.background = look.background;
        self.materials = look.materials;
        self.textures = look.textures;
        Ok(self)
    }

    /// This scene over another BVH, with the traversal's copies of the
    /// geometry remade in its leaf order: for tests that hand-edit a tree
    /// ([`Bvh::from_parts`], which checks its layout), so that the edit
    /// reaches the traversal. Refused if the tree indexes a primitive the
    /// scene lacks.
    pub fn with_bvh(mut self, bvh: Bvh) -> Result<Scene, SceneError> {
        let count = self.primitives.len();
        if let Some(p) = bvh.prim_order().iter().find(|&&p| p as usize >= count) {
            return Err(SceneError::invalid(
                "bvh",
                format!("the tree indexes primitive {p} of a scene of {count}"),
            ));
        }
        self.put_bvh(bvh);
        Ok(self)
    }
}
