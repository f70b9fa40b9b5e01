//! Where a render runs ([`Devices`]) and the one place a backend is
//! chosen for it ([`open`]).

use super::cpu::CpuProgressive;
use super::gpu::GpuProgressive;
use super::group::GroupProgressive;
use super::progressive::Progressive;
use super::spec::RenderSpec;
use anyhow::Result;
use reference::{RenderSettings, Scene};

/// Where a progressive render runs: the CPU reference (in a thread pool
/// where one is given), one GPU, or several. `Copy`: a caller keeps it to
/// open the render again (the viewer, on a change of spec).
#[derive(Clone, Copy)]
pub enum Devices<'a> {
    Cpu(Option<&'a rayon::ThreadPool>),
    Gpu(&'a gpu::GpuContext),
    Gpus(&'a [gpu::GpuContext]),
}

/// Opens a progressive render of `scene` with `spec` on `devices`: the
/// one place a backend is chosen for a render.
pub fn open<'a>(
    devices: Devices<'a>,
    scene: &'a Scene,
    spec: &RenderSpec,
    settings: RenderSettings,
) -> Result<Box<dyn Progressive + 'a>> {
    Ok(match devices {
        Devices::Cpu(pool) => Box::new(CpuProgressive::new(scene, spec, settings, pool)?),
        Devices::Gpu(ctx) => Box::new(GpuProgressive::new(ctx, scene, spec, settings)?),
        Devices::Gpus(contexts) => {
            Box::new(GroupProgressive::new(contexts, scene, spec, settings)?)
        }
    })
}
