//! The CPU reference as a progressive render.

use super::progressive::{check, Added, Layers, Progressive, Ranges};
use super::spec::RenderSpec;
use anyhow::{anyhow, bail, Result};
use reference::aov::AovSums;
use reference::film::FilmSums;
use reference::integrator::Integrator;
use reference::{RenderSettings, Scene};
use std::ops::Range;

/// The scalar CPU reference as a [`Progressive`] render: each range is
/// traced by `reference::integrator::render_samples` (rayon over tiles, in
/// `pool` where one is given) and its sums are added to the film.
pub struct CpuProgressive<'a> {
    scene: &'a Scene,
    integrator: Integrator,
    settings: RenderSettings,
    pool: Option<&'a rayon::ThreadPool>,
    film: FilmSums,
    ranges: Ranges,
}

impl<'a> CpuProgressive<'a> {
    pub fn new(
        scene: &'a Scene,
        spec: &RenderSpec,
        settings: RenderSettings,
        pool: Option<&'a rayon::ThreadPool>,
    ) -> Result<Self> {
        check(&settings)?;
        Ok(Self {
            scene,
            integrator: spec.integrator(),
            film: FilmSums::new(settings.width, settings.height),
            settings,
            pool,
            ranges: Ranges::default(),
        })
    }
}

impl Progressive for CpuProgressive<'_> {
    fn device(&self) -> String {
        "cpu reference".into()
    }

    fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    fn add(&mut self, samples: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> Result<Added> {
        self.add_until(samples, progress, &|| false)?
            .ok_or_else(|| anyhow!("a range that is never stopped was stopped"))
    }

    fn add_until(
        &mut self,
        samples: Range<u32>,
        progress: &(dyn Fn(u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<Option<Added>> {
        let mut ranges = self.ranges.clone();
        ranges.insert(samples.clone())?;
        let n = (samples.end - samples.start) as u64;
        let settings = RenderSettings {
            spp: samples.end - samples.start,
            ..self.settings
        };
        check(&settings)?;
        let (scene, integrator) = (self.scene, self.integrator);
        let pixel_progress = |pixels: u64| progress(pixels * n);
        let render = || {
            reference::integrator::render_samples_until(
                scene,
                &settings,
                integrator,
                samples.clone(),
                &pixel_progress,
                stop,
            )
        };
        let sums = match self.pool {
            Some(pool) => pool.install(render),
            None => render(),
        };
        let Some(sums) = sums else {
            return Ok(None);
        };
        self.film.merge(&sums).map_err(|e| anyhow!(e))?;
        self.ranges = ranges;
        Ok(Some(Added::default()))
    }

    fn sums(&mut self) -> Result<FilmSums> {
        Ok(self.film.clone())
    }

    fn layers(&mut self) -> Result<Layers> {
        Ok(Layers::from_sums(&self.film))
    }

    fn aovs(&mut self, samples: Range<u32>) -> Result<AovSums> {
        if samples.start >= samples.end {
            bail!(
                "the sample range {}..{} is empty",
                samples.start,
                samples.end
            );
        }
        let settings = self.settings;
        let mut sums = AovSums::new(settings.width, settings.height);
        let scene = self.scene;
        let render = || reference::aov::render_aovs(scene, &settings, samples, &mut sums);
        match self.pool {
            Some(pool) => pool.install(render),
            None => render(),
        }
        Ok(sums)
    }

    fn reset(&mut self, settings: RenderSettings) -> Result<()> {
        check(&settings)?;
        self.film = FilmSums::new(settings.width, settings.height);
        self.settings = settings;
        self.ranges.clear();
        Ok(())
    }

    fn ranges(&self) -> &[Range<u32>] {
        self.ranges.as_slice()
    }
}
