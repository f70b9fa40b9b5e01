//! Render settings and the limits that keep a render's size sane.

use crate::camera::CameraSettings;
use crate::error::SceneError;

/// Render parameters a scene proposes; the command line overrides them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub max_depth: u32,
    pub seed: u32,
    /// Path vertex index from which Russian roulette may end paths.
    pub roulette_depth: u32,
    /// The sequence the paths' random numbers come from.
    pub sampler: crate::rng::Sampler,
    /// The camera, where it is not the scene's own (the viewer's moved
    /// camera, a saved view's).
    pub camera: Option<CameraSettings>,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 400,
            height: 300,
            spp: 64,
            max_depth: 16,
            seed: 0,
            roulette_depth: 3,
            sampler: crate::rng::Sampler::default(),
            camera: None,
        }
    }
}

/// Limits on render parameters: beyond them an image is a mistake, not a
/// request. Whether this machine can hold a render of a size within them
/// is checked against its memory where the render starts (the CLI's
/// `twintrace::host_memory`), so a 15360x8640 frame renders where the
/// memory is there (a GPU film in bands) and is refused in one line where
/// it is not.
pub const MAX_IMAGE_SIDE: u32 = 16_384;

pub const MAX_SPP: u32 = 1 << 24;

pub const MAX_DEPTH: u32 = 1024;

impl RenderSettings {
    /// Checks the parameters; the error names the offending field.
    pub fn validate(&self) -> Result<(), SceneError> {
        if let Some(camera) = &self.camera {
            camera.validate()?;
        }
        let bad = |field: &str, msg: String| Err(SceneError::invalid(field, msg));
        if self.width == 0
            || self.height == 0
            || self.width > MAX_IMAGE_SIDE
            || self.height > MAX_IMAGE_SIDE
        {
            return bad(
                "render.width/height",
                format!(
                    "image size {}x{} must be between 1x1 and {MAX_IMAGE_SIDE}x{MAX_IMAGE_SIDE}",
                    self.width, self.height
                ),
            );
        }
        if self.spp == 0 || self.spp > MAX_SPP {
            return bad(
                "render.spp",
                format!(
                    "{} samples per pixel must be between 1 and {MAX_SPP}",
                    self.spp
                ),
            );
        }
        if self.max_depth == 0 || self.max_depth > MAX_DEPTH {
            return bad(
                "render.max_depth",
                format!(
                    "max depth {} must be between 1 and {MAX_DEPTH}",
                    self.max_depth
                ),
            );
        }
        Ok(())
    }
}
