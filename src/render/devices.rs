//! Where a render runs ([`Devices`]), the one place a backend is chosen
//! for it ([`open`]), and a renderer as its clients hold one: where and
//! what ([`Renderer`]).

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

impl<'a> Devices<'a> {
    /// Where a render on `gpus` runs: the CPU reference (in `pool`, where
    /// one is given) when there is none, the one GPU, or the group of
    /// several (whose image is the one GPU's, bit for bit, on devices of
    /// one kind).
    pub fn of(gpus: &'a [gpu::GpuContext], pool: Option<&'a rayon::ThreadPool>) -> Self {
        match gpus {
            [] => Devices::Cpu(pool),
            [one] => Devices::Gpu(one),
            several => Devices::Gpus(several),
        }
    }
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

/// A renderer: where it renders and what ([`RenderSpec`]). `Copy`, like
/// [`Devices`]: selftest's gates and calibrations and perf's rows each
/// open renders of many scenes with one.
#[derive(Clone, Copy)]
pub struct Renderer<'a> {
    pub devices: Devices<'a>,
    pub spec: RenderSpec,
}

impl<'a> Renderer<'a> {
    /// A progressive render of `scene` ([`open`]).
    pub fn open<'s>(
        &self,
        scene: &'s Scene,
        settings: RenderSettings,
    ) -> Result<Box<dyn Progressive + 's>>
    where
        'a: 's,
    {
        open(self.devices, scene, &self.spec, settings)
    }

    /// A function rendering `scene` with any settings: the scene opened
    /// once (a GPU uploads it and builds its kernels once), its film
    /// emptied for each render.
    pub fn prepare<'s>(
        &self,
        scene: &'s Scene,
    ) -> Result<impl Fn(&RenderSettings) -> Result<reference::Film> + 's>
    where
        'a: 's,
    {
        let render = std::cell::RefCell::new(self.open(scene, scene.render_settings())?);
        Ok(move |settings: &RenderSettings| {
            super::progressive::render_film(render.borrow_mut().as_mut(), settings)
        })
    }
}
