//! glTF materials as the renderer's: metallic-roughness GGX, emission,
//! alpha, clear coat and the transmissive dielectric.

use super::bounds;
use super::extensions::CLEARCOAT;
use super::textures::{Decoding, Importer, TextureRef};
use crate::error::SceneError;
use crate::material::{Alpha, AlphaMode, ClearCoat, Material, NormalMap};
use crate::scene::SceneBuilder;
use glam::Vec3;

/// The coordinate sets the material's textures read (a normal texture
/// whose transform does not parse is left out: importing the material
/// reports it).
pub(super) fn texture_sets(material: &gltf::Material) -> Vec<u32> {
    let pbr = material.pbr_metallic_roughness();
    let infos = [
        pbr.base_color_texture(),
        pbr.metallic_roughness_texture(),
        material.emissive_texture(),
    ];
    let mut sets: Vec<u32> = infos
        .iter()
        .flatten()
        .map(|info| TextureRef::of(info).set())
        .collect();
    sets.extend(normal_map_set(material).ok().flatten());
    sets
}

/// The texture coordinate set the material's normal map reads (`None`:
/// the material has no normal map); an error names the material.
pub(super) fn normal_map_set(material: &gltf::Material) -> Result<Option<u32>, String> {
    match material.normal_texture() {
        Some(normal) => Ok(Some(
            TextureRef::of_normal(&normal)
                .map_err(|m| format!("{}: normalTexture.{m}", material_named(material)))?
                .set(),
        )),
        None => Ok(None),
    }
}

/// How errors and warnings name a material ([`bounds::named`]).
fn material_named(material: &gltf::Material) -> String {
    match material.index() {
        Some(i) => bounds::named("material", &format!("materials[{i}]"), material.name()),
        None => "default material".to_string(),
    }
}

impl Importer<'_> {
    pub(super) fn material(
        &mut self,
        builder: &mut SceneBuilder,
        material: gltf::Material,
    ) -> Result<u32, SceneError> {
        let key = material.index();
        if let Some(&id) = self.materials.get(&key) {
            return Ok(id);
        }
        let context = material_named(&material);
        let file = self.file;
        let in_context = |e: SceneError| e.within(&context).in_file(&file.path);
        let fail = |m: String| file.error(format!("{context}: {m}"));
        // Every number the specification bounds, before anything is made
        // of them: an error names the field, not what it became.
        bounds::material(&material).map_err(fail)?;
        let pbr = material.pbr_metallic_roughness();
        let emission =
            Vec3::from(material.emissive_factor()) * material.emissive_strength().unwrap_or(1.0);
        let glass = self
            .dielectric(builder, &material, &context)
            .map_err(fail)?;
        // Added to the BSDF below: the surface keeps what it reflects.
        let emission = if emission != Vec3::ZERO {
            Some(self.factored_texture(
                builder,
                material.emissive_texture(),
                (emission, Decoding::Srgb),
                &context,
                ("emissiveTexture", "emissiveFactor"),
            )?)
        } else {
            None
        };
        let converted = if let Some(glass) = glass {
            glass
        } else {
            let [r, g, b, _alpha] = pbr.base_color_factor();
            let factor = Vec3::new(r, g, b);
            let texture = self.factored_texture(
                builder,
                pbr.base_color_texture(),
                (factor, Decoding::Srgb),
                &context,
                ("pbrMetallicRoughness.baseColorTexture", "baseColorFactor"),
            )?;
            let metallic_roughness = match pbr.metallic_roughness_texture() {
                Some(info) => Some(self.data_texture(
                    builder,
                    &TextureRef::of(&info),
                    &context,
                    "pbrMetallicRoughness.metallicRoughnessTexture",
                )?),
                None => None,
            };
            let normal_map = match material.normal_texture() {
                Some(normal) => {
                    let texture = TextureRef::of_normal(&normal)
                        .map_err(|m| file.error(format!("{context}: normalTexture.{m}")))?;
                    Some(NormalMap {
                        texture: self.data_texture(builder, &texture, &context, "normalTexture")?,
                        scale: normal.scale(),
                    })
                }
                None => None,
            };
            Material::Ggx {
                base_color: texture,
                metallic: pbr.metallic_factor(),
                roughness: pbr.roughness_factor(),
                metallic_roughness,
                normal_map,
                clearcoat: self.clearcoat(builder, &material, &context)?,
            }
        };
        use gltf::material::AlphaMode as Mode;
        let mode = match material.alpha_mode() {
            Mode::Opaque => None,
            // The cutoff is checked with the other numbers above.
            Mode::Mask => Some(AlphaMode::Mask {
                cutoff: material.alpha_cutoff().unwrap_or(0.5),
            }),
            Mode::Blend => Some(AlphaMode::Blend),
        };
        let alpha = match mode {
            Some(mode) => Some(Alpha {
                texture: self.alpha_texture(builder, &material, &context)?,
                mode,
            }),
            None => None,
        };
        if !matches!(converted, Material::Ggx { .. }) {
            let kind = "the dielectric";
            let ignored = [
                ("normalTexture", material.normal_texture().is_some()),
                (CLEARCOAT, material.extension_value(CLEARCOAT).is_some()),
            ];
            let lost: Vec<String> = ignored
                .iter()
                .filter(|(_, present)| *present)
                .map(|(what, _)| format!("{what} ignored on {kind}"))
                .collect();
            self.warn(builder, &context, &lost);
        }
        let id = builder.add_material(converted).map_err(in_context)?;
        if let Some(emission) = emission {
            builder
                .set_emission(id, emission)
                .map_err(|e| in_context(e.within("emissiveFactor")))?;
        }
        if let Some(alpha) = alpha {
            builder
                .set_alpha(id, alpha)
                .map_err(|e| in_context(e.within("alphaMode")))?;
        }
        self.materials.insert(key, id);
        Ok(id)
    }

    /// The texture whose first channel is the material's alpha: the base
    /// colour texture's alpha channel (linear, with the base colour's
    /// sampler, transform and coordinate set) times `baseColorFactor`'s
    /// alpha, or that factor alone. The vertex colour's alpha multiplies
    /// it at each hit ([`Scene::alpha_covers`](crate::scene::Scene::alpha_covers)).
    fn alpha_texture(
        &mut self,
        builder: &mut SceneBuilder,
        material: &gltf::Material,
        context: &str,
    ) -> Result<u32, SceneError> {
        let pbr = material.pbr_metallic_roughness();
        let factor = Vec3::splat(pbr.base_color_factor()[3]);
        self.factored_texture(
            builder,
            pbr.base_color_texture(),
            (factor, Decoding::Alpha),
            context,
            ("pbrMetallicRoughness.baseColorTexture", "baseColorFactor"),
        )
    }

    /// `KHR_materials_clearcoat` as the GGX material's [`ClearCoat`]
    /// (`None` where the extension is absent or its factor is 0). The
    /// `gltf` crate has no typed accessor, so the object is read as JSON:
    /// the factors must be numbers in [0, 1] and the textures' references
    /// valid, like any texture's. `clearcoatNormalTexture` is one warning
    /// line: the coat shares the base's shading normal.
    fn clearcoat(
        &mut self,
        builder: &mut SceneBuilder,
        material: &gltf::Material,
        context: &str,
    ) -> Result<Option<ClearCoat>, SceneError> {
        let Some(value) = material.extension_value(CLEARCOAT) else {
            return Ok(None);
        };
        let file = self.file;
        let error = |m: String| file.error(format!("{context}: extensions.{CLEARCOAT}{m}"));
        let object = value
            .as_object()
            .ok_or_else(|| error(" is not an object".into()))?;
        // Both factors in [0, 1] (the extension's schema).
        let factor = |name: &str| match object.get(name) {
            None => Ok(0.0),
            Some(v) => {
                let x = v
                    .as_f64()
                    .ok_or_else(|| error(format!(".{name} {v} is not a number")))?
                    as f32;
                bounds::number(name, x, bounds::Range::Unit).map_err(|m| error(format!(".{m}")))?;
                Ok(x)
            }
        };
        let weight = factor("clearcoatFactor")?;
        let roughness = factor("clearcoatRoughnessFactor")?;
        let texture =
            self.extension_texture(builder, object, CLEARCOAT, "clearcoatTexture", context)?;
        let roughness_texture = self.extension_texture(
            builder,
            object,
            CLEARCOAT,
            "clearcoatRoughnessTexture",
            context,
        )?;
        if object.contains_key("clearcoatNormalTexture") {
            self.warn(
                builder,
                context,
                &[format!(
                    "{CLEARCOAT}.clearcoatNormalTexture ignored (the coat follows the base's shading normal)"
                )],
            );
        }
        if weight == 0.0 {
            return Ok(None);
        }
        Ok(Some(ClearCoat {
            factor: weight,
            texture,
            roughness,
            roughness_texture,
        }))
    }

    /// `KHR_materials_transmission` as the reference's smooth dielectric,
    /// with `KHR_materials_ior`'s index (1.5 without it) and, where
    /// `KHR_materials_volume` gives the material a thickness, its
    /// Beer-Lambert absorption `-ln(attenuationColor) / attenuationDistance`
    /// per unit length; `None` for a material that transmits nothing (no
    /// extension, a zero factor, or fully metallic). What the dielectric
    /// cannot show (partial or textured transmission, roughness, the base
    /// colour's tint, a thin wall) is one warning line per material. An
    /// `ior` on an opaque material is a warning too: the GGX material's
    /// dielectric F0 is 0.04 (ior 1.5).
    fn dielectric(
        &self,
        builder: &mut SceneBuilder,
        material: &gltf::Material,
        context: &str,
    ) -> Result<Option<Material>, String> {
        let pbr = material.pbr_metallic_roughness();
        // In range ([`bounds::material`]): 1 and above, or 0.
        let ior = material.ior();
        let transmission = material
            .transmission()
            .filter(|t| t.transmission_factor() > 0.0 && pbr.metallic_factor() < 1.0);
        let mut lost: Vec<String> = Vec::new();
        let Some(transmission) = transmission else {
            if let Some(ior) = ior.filter(|&i| i != 1.5) {
                lost.push(format!(
                    "KHR_materials_ior {ior} ignored on an opaque material (its specular F0 stays 0.04, ior 1.5)"
                ));
            }
            self.warn(builder, context, &lost);
            return Ok(None);
        };
        if ior == Some(0.0) {
            return Err(
                "extensions.KHR_materials_ior.ior 0 (an infinite index) cannot be a transmissive material's"
                    .into(),
            );
        }
        let mut absorption = Vec3::ZERO;
        match material.volume() {
            Some(v) if v.thickness_factor() > 0.0 => {
                // Above 0, or infinite (no absorption): [`bounds::material`].
                let distance = v.attenuation_distance();
                if distance.is_finite() {
                    // A channel that keeps nothing (colour 0) is given
                    // 1e-6 of its light per attenuationDistance: opaque
                    // in practice, and a finite coefficient.
                    let colour =
                        Vec3::from(v.attenuation_color()).clamp(Vec3::splat(1e-6), Vec3::ONE);
                    absorption = -Vec3::from(colour.to_array().map(f32::ln)) / distance;
                    // Each term is at most ln(1e6) ≈ 13.8 over the
                    // distance: a distance below about 4e-38 (in range,
                    // above 0) overflows it.
                    if !absorption.is_finite() {
                        return Err(format!(
                            "extensions.KHR_materials_volume.attenuationDistance {} is too small: with attenuationColor {} the absorption −ln(colour) / distance is beyond the range of a 32-bit float",
                            bounds::show(distance),
                            bounds::show_all(&v.attenuation_color())
                        ));
                    }
                }
            }
            _ => lost.push(
                "thin-walled (no KHR_materials_volume thickness): rendered as solid glass".into(),
            ),
        }
        let factor = transmission.transmission_factor();
        if factor < 1.0 {
            lost.push(format!(
                "transmissionFactor {factor} rendered as 1 (the dielectric transmits fully)"
            ));
        }
        if transmission.transmission_texture().is_some() {
            lost.push("transmissionTexture ignored".into());
        }
        if pbr.roughness_factor() > 0.0 || pbr.metallic_roughness_texture().is_some() {
            lost.push(format!(
                "roughness {} rendered smooth (the dielectric is smooth)",
                pbr.roughness_factor()
            ));
        }
        if pbr.metallic_factor() > 0.0 {
            lost.push(format!("metallicFactor {} ignored", pbr.metallic_factor()));
        }
        let [r, g, b, _] = pbr.base_color_factor();
        if Vec3::new(r, g, b) != Vec3::ONE || pbr.base_color_texture().is_some() {
            lost.push("the base colour's tint of transmitted light ignored".into());
        }
        self.warn(builder, context, &lost);
        Ok(Some(Material::Dielectric {
            ior: ior.unwrap_or(1.5),
            absorption,
        }))
    }
}
