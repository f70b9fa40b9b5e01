//! glTF 2.0 import (`.gltf` with external or `data:` buffers, and `.glb`).
//!
//! Three entry points:
//! - [`load_gltf_mesh`]: every triangle of the document's scene, placed by
//!   the node hierarchy and merged into one [`MeshInput`] (the scene file's
//!   `mesh` object, whose material overrides the file's);
//! - [`add_gltf_scene`]: the scene with its own materials, one
//!   `SceneBuilder::add_mesh` per primitive instance (the `gltf` object);
//! - [`load_gltf_document`]: a whole document as a [`Scene`].
//!
//! The last two have `_with` forms ([`add_gltf_scene_with`],
//! [`load_gltf_document_with`]) that take [`GltfOptions`]: how the lights'
//! intensities are read ([`GltfLightUnits`]).
//!
//! Extensions: the importer implements those of [`SUPPORTED_EXTENSIONS`],
//! and checks `extensionsRequired` itself (`check_required`): a
//! document that requires one of them loads, one that requires another
//! is refused, naming it (`extensionsRequired[1] = "KHR_draco_mesh_compression":
//! not supported by twintrace`). (The `gltf` crate would refuse every
//! required extension outside its own feature list, `KHR_lights_punctual`
//! among them, so its validation runs without the list.) Other extensions
//! in `extensionsUsed` are ignored with one warning line
//! ([`Scene::warnings`], printed by the CLI).
//!
//! Which nodes: the default scene, else the first scene; a document without
//! scenes contributes every mesh once, untransformed. Nodes are walked
//! depth first in document order; a node reached twice (the hierarchy is
//! not a forest) is an error, so cycles cannot hang the loader. A node's
//! `rotation` must be a unit quaternion: one within glTF-Validator's
//! bound of unit length is normalized (a warning line where it is off by
//! more than a rounded unit quaternion is, `bounds::ROTATION_QUIET`),
//! one further off is an error (`bounds::node_transform`).
//!
//! Geometry: `Triangles`, `TriangleStrip` and `TriangleFan` primitives are
//! imported (strips and fans are converted to triangles as the glTF spec
//! defines them); points and lines are skipped. Attributes read: POSITION,
//! NORMAL, TEXCOORD_0 and TEXCOORD_1, COLOR_0 (RGB or RGBA) and TANGENT
//! (kept only where the material has a normal map, and ignored without
//! NORMAL, as the spec says), stored as float or (normalized) integers,
//! dense or sparse. glTF's texture origin is the top-left corner and the
//! reference's the bottom-left, so `v` becomes `1 - v`. Normals go through
//! the inverse transpose of the node's matrix, tangents through the matrix
//! (their `w` changing sign under a mirror), and a node whose matrix
//! mirrors (negative determinant) has its triangles' winding reversed so
//! that front faces stay front faces, as the glTF spec requires. A
//! primitive whose material has a normal map but no TANGENT gets MikkTSpace
//! tangents ([`with_generated_tangents`]). The `mesh` object
//! ([`load_gltf_mesh`]) keeps positions, normals and TEXCOORD_0 only: its
//! material is the scene file's.
//!
//! Materials (metallic-roughness): `baseColorFactor` and
//! `baseColorTexture` (their RGB) become the base colour of a
//! [`Material::Ggx`] with `metallicFactor` and `roughnessFactor`. A
//! material's emission (`emissiveFactor` × `KHR_materials_emissive_strength`,
//! times `emissiveTexture` where it has one), where it is non-zero, is
//! added to its BSDF ([`SceneBuilder::set_emission`]), as glTF defines it:
//! the surface keeps its base colour, metal-roughness and normal map, and
//! emits from its front face (glTF's `doubleSided` is not read). A
//! material that transmits (`KHR_materials_transmission`, with
//! `KHR_materials_ior` and `KHR_materials_volume`) becomes a
//! [`Material::Dielectric`] (`Importer::dielectric` says how, and what is
//! lost is one warning line). The `metallicRoughnessTexture` scales the
//! factors per point (blue: metallic, green: roughness;
//! `material::ggx_parameters`); vertex colours scale the base colour; the
//! `normalTexture` bends the GGX material's shading normal
//! ([`crate::material::normal_mapped`]); `KHR_materials_clearcoat` lays
//! a [`crate::material::ClearCoat`] over it (`Importer::clearcoat`; its
//! `clearcoatNormalTexture` is a warning: the coat follows the base's
//! shading normal). A texture reads the coordinate
//! set its `texCoord` (or its transform's) names, 0 or 1 (a set above 1 is
//! a warning, and TEXCOORD_0 is read). Not supported (ignored): the
//! occlusion texture (occlusion is baked ambient light, which a path
//! tracer computes itself), `doubleSided` (other
//! materials shade both sides anyway; emitters emit from the front face
//! only), skins, morph targets, animations and orthographic cameras.
//! `alphaMode` MASK (with `alphaCutoff`, 0.5 by default) and BLEND give
//! the material a coverage ([`crate::material::Alpha`]): the alpha of the
//! base colour texture (its own decoding, [`Decoding::Alpha`]) times the
//! factor's and the vertex colour's, tested where the traversal accepts a
//! hit; BLEND is stochastic transparency ([`AlphaMode::Blend`]).
//! A primitive without a material gets the spec's default material: base
//! colour 1, metallic 1, roughness 1. Each glTF material, texture/factor
//! pair and image is added to the builder once.
//!
//! Lights (`KHR_lights_punctual`): each node holding a light adds it
//! ([`SceneBuilder::add_light`]) at the node's world position, pointing
//! along the node's −Z. The extension's `intensity` is photometric:
//! candela (lm/sr) for point and spot lights, lux (lm/m²) for directional
//! ones. The renderer's lights are radiometric, per channel: radiant
//! intensity (W/sr) and irradiance (W/m²). By default
//! ([`GltfLightUnits::Photometric`]) `color` × `intensity` /
//! [`LUMENS_PER_WATT`] (683 lm/W, as Blender's glTF importer converts) is
//! what the renderer gets; [`GltfLightUnits::Radiometric`] takes
//! `color` × `intensity` as watts already (for files whose writer put
//! them there). A
//! spot's `innerConeAngle` and `outerConeAngle` (defaults 0 and π/4)
//! shape its falloff as the extension's reference formula does
//! ([`crate::light::PunctualLight::falloff`]). `range` is not honoured:
//! a light that states one falls off by the inverse square law alone, and
//! the importer says so in one warning line per light.
//!
//! Textures keep their sampler (wrap modes per axis: repeat, clamp to
//! edge, mirrored repeat; a NEAREST magnification filter) and their
//! `KHR_texture_transform` (offset, rotation, scale), rewritten for the
//! renderer's uv convention (`sampler`); the renderer builds no mipmaps,
//! so minification filters are read as the magnification one.
//!
//! Images are decoded by the `gltf` crate (PNG, JPEG), only when a material
//! uses them. 8- and 16-bit channels of base colour and emissive textures
//! are sRGB-encoded colour and are decoded to linear, those of the
//! metallic-roughness texture linear data (an image used both ways is
//! decoded once each way); float images are taken as linear. Grey images
//! become grey RGB; the alpha channel is decoded (linear) into an image of
//! its own where a material's alpha mode reads it. Row 0 of the decoded image is the top row, as in [`ImageData`].
//!
//! Every problem in the file (unreadable, not glTF, a buffer that is
//! missing or too short, an accessor that reaches past its buffer, an
//! index out of range, a value of the wrong type, a number outside the
//! bounds the specification gives it or an attribute of an accessor type
//! it does not allow ([`bounds`]), ...) is an error that names the file,
//! the element (by name and index) and the field; the `gltf` crate's code
//! paths that would panic on such input are checked for beforehand or not
//! used.
//!
//! [`MeshInput`]: crate::scene::MeshInput
//! [`Scene`]: crate::scene::Scene
//! [`Scene::warnings`]: crate::scene::Scene::warnings
//! [`SceneBuilder::add_light`]: crate::scene::SceneBuilder::add_light
//! [`SceneBuilder::set_emission`]: crate::scene::SceneBuilder::set_emission
//! [`Material::Ggx`]: crate::material::Material::Ggx
//! [`Material::Dielectric`]: crate::material::Material::Dielectric
//! [`AlphaMode::Blend`]: crate::material::AlphaMode::Blend
//! [`ImageData`]: crate::texture::ImageData
//! [`with_generated_tangents`]: meshes::with_generated_tangents
//! [`Decoding::Alpha`]: textures::Decoding::Alpha

mod accessors;
mod bounds;
mod document;
mod extensions;
mod import;
mod lights;
mod materials;
mod meshes;
mod nodes;
mod textures;
mod uv_transform;

pub use extensions::SUPPORTED_EXTENSIONS;
pub use import::{
    add_gltf_scene, add_gltf_scene_with, load_gltf_document, load_gltf_document_bytes,
    load_gltf_document_with, load_gltf_mesh, load_gltf_mesh_reading, GltfOptions, DEFAULT_VFOV,
};
pub use lights::{GltfLightUnits, LUMENS_PER_WATT};

#[cfg(test)]
mod tests;
