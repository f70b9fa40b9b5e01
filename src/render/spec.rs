//! What a render is: [`RenderSpec`], the estimator, the GPU's variant
//! axes and the display transform, with their defaults defined once.

use crate::tonemap::Tonemap;
use reference::integrator::Integrator;

/// What a render is compiled and traced for, besides the scene and its
/// settings (size, samples, depth, seed): the estimator and the GPU's
/// variant axes ([`gpu::Variant`]; the CPU reference reads only the
/// estimator) and the display transform of its PNG.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderSpec {
    pub variant: gpu::Variant,
    pub tonemap: Tonemap,
}

impl RenderSpec {
    /// Every default, in one place: [`gpu::Variant::DEFAULT`] (MIS, the
    /// path megakernel, ...) and the ACES tone map.
    pub const DEFAULT: RenderSpec = RenderSpec {
        variant: gpu::Variant::DEFAULT,
        tonemap: Tonemap::Aces,
    };

    pub fn integrator(&self) -> Integrator {
        self.variant.integrator
    }

    /// The spec with another estimator.
    pub fn with_integrator(self, integrator: Integrator) -> Self {
        RenderSpec {
            variant: gpu::Variant {
                integrator,
                ..self.variant
            },
            ..self
        }
    }
}

impl Default for RenderSpec {
    fn default() -> Self {
        Self::DEFAULT
    }
}
