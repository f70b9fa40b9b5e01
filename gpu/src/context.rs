//! Adapters and devices: choosing one, listing them, opening it with the
//! limits the kernels need, and turning wgpu's asynchronous errors
//! (validation, device loss) into `GpuError`s instead of panics.

use crate::error::GpuError;
use std::sync::{Arc, Mutex};

/// A summary of one adapter for `twintrace info`.
#[derive(Clone, Debug)]
pub struct AdapterSummary {
    pub name: String,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
    pub max_storage_buffer_binding_size: u64,
    pub max_buffer_size: u64,
    pub max_storage_buffers_per_shader_stage: u32,
    pub max_compute_invocations_per_workgroup: u32,
    pub timestamp_queries: bool,
}

/// An instance of `backends` only (less any `WGPU_BACKEND` leaves out):
/// an instance of every backend would start OpenGL's too, which costs
/// time on every run even where the native backend has the adapter.
fn instance(backends: wgpu::Backends) -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    desc.backends &= backends;
    wgpu::Instance::new(desc)
}

fn summarize(a: &wgpu::Adapter) -> AdapterSummary {
    let info = a.get_info();
    let l = a.limits();
    AdapterSummary {
        name: info.name,
        backend: format!("{:?}", info.backend),
        device_type: format!("{:?}", info.device_type),
        driver: format!("{} {}", info.driver, info.driver_info)
            .trim()
            .to_string(),
        max_storage_buffer_binding_size: l.max_storage_buffer_binding_size,
        max_buffer_size: l.max_buffer_size,
        max_storage_buffers_per_shader_stage: l.max_storage_buffers_per_shader_stage,
        max_compute_invocations_per_workgroup: l.max_compute_invocations_per_workgroup,
        timestamp_queries: a.features().contains(wgpu::Features::TIMESTAMP_QUERY),
    }
}

/// Native backends first; OpenGL only when none of them has an adapter
/// (probing GL also prints windowing-system noise on headless machines).
fn adapters() -> Vec<wgpu::Adapter> {
    let native = pollster::block_on(
        instance(wgpu::Backends::PRIMARY).enumerate_adapters(wgpu::Backends::PRIMARY),
    );
    if !native.is_empty() {
        return native;
    }
    pollster::block_on(instance(wgpu::Backends::GL).enumerate_adapters(wgpu::Backends::GL))
}

/// Every adapter twintrace would consider.
pub fn list_adapters() -> Vec<AdapterSummary> {
    adapters().iter().map(summarize).collect()
}

/// The adapters in [`list_adapters`]'s order (the indices `--devices`
/// names).
pub(crate) fn adapters_in_order() -> Vec<wgpu::Adapter> {
    adapters()
}

/// Ranks adapters: discrete > integrated > virtual > CPU (lavapipe) >
/// other; Vulkan before the other backends at equal type.
fn rank(a: &wgpu::Adapter) -> (u32, u32) {
    let info = a.get_info();
    let t = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    let b = if info.backend == wgpu::Backend::Vulkan {
        0
    } else {
        1
    };
    (t, b)
}

/// An open device with its queue and what we know about it.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter: AdapterSummary,
    pub is_software: bool,
    pub timestamps: bool,
    lost: Arc<Mutex<Option<String>>>,
    uncaptured: Arc<Mutex<Option<String>>>,
    /// Compute pipelines created on the device ([`Self::pipelines_built`]).
    pipelines: std::sync::atomic::AtomicU64,
    /// Modules, layouts and pipelines built on the device.
    pub(crate) caches: crate::pipeline::cache::Caches,
    /// The driver's pipeline cache and its file, where the adapter has one.
    pub(crate) disk_cache: Option<crate::pipeline::cache::DiskCache>,
    /// What the caller should tell the user ([`Self::take_warnings`]).
    warnings: Mutex<Vec<String>>,
}

/// Opens a device on adapter `index` of [`list_adapters`]'s order, with
/// its pipeline cache in `cache_dir` (`None`: none on disk).
pub fn open_adapter(
    index: usize,
    cache_dir: Option<&std::path::Path>,
) -> Result<GpuContext, GpuError> {
    let adapters = adapters_in_order();
    let adapter = adapters.get(index).ok_or_else(|| {
        GpuError::Validation(format!(
            "there is no adapter {index} (this machine has {})",
            adapters.len()
        ))
    })?;
    GpuContext::open_with_cache(adapter, cache_dir)
}

impl GpuContext {
    /// Opens the best adapter that can run the kernels.
    pub fn new() -> Result<Self, GpuError> {
        let mut all = adapters();
        all.sort_by_key(rank);
        let mut last_err = None;
        for a in all {
            match Self::open(&a) {
                Ok(ctx) => return Ok(ctx),
                Err(e) => last_err = Some(e),
            }
        }
        Err(last_err.unwrap_or(GpuError::NoAdapter))
    }

    /// Opens a device on `adapter`, if it can run the kernels, with the
    /// on-disk pipeline cache in [`crate::pipeline::cache_dir`] on a
    /// hardware adapter. A software adapter (lavapipe) gets none: its
    /// driver cache holds every pipeline's machine code, megabytes each,
    /// for the life of the device (the test suite's one device grew past
    /// 20 GB with it).
    pub fn open(adapter: &wgpu::Adapter) -> Result<Self, GpuError> {
        let software = adapter.get_info().device_type == wgpu::DeviceType::Cpu;
        let dir = if software {
            None
        } else {
            crate::pipeline::cache::cache_dir()
        };
        Self::open_with_cache(adapter, dir.as_deref())
    }

    /// [`Self::open`] with the pipeline cache's folder given (`None`: no
    /// cache on disk).
    pub fn open_with_cache(
        adapter: &wgpu::Adapter,
        cache_dir: Option<&std::path::Path>,
    ) -> Result<Self, GpuError> {
        let summary = summarize(adapter);
        let al = adapter.limits();
        let software = adapter.get_info().device_type == wgpu::DeviceType::Cpu;
        // The render kernel's storage buffers (scene arrays, film; the
        // params too on a software adapter) are needed; as many as the
        // wavefront's wf_prepare binds (three more: paths, queues, dispatch
        // arguments; the test kernels two, input and output) are asked
        // for where the adapter has them.
        let needed = crate::bindings::render_storage_buffers(software);
        let wanted = crate::bindings::wavefront_storage_buffers(software);
        if al.max_storage_buffers_per_shader_stage < needed {
            return Err(GpuError::UnsuitableAdapter {
                adapter: summary.name,
                reason: format!(
                    "it allows {} storage buffers per shader stage, the kernels need {needed}",
                    al.max_storage_buffers_per_shader_stage
                ),
            });
        }
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let limits = wgpu::Limits {
            max_storage_buffers_per_shader_stage: al
                .max_storage_buffers_per_shader_stage
                .min(wanted),
            max_storage_buffer_binding_size: al.max_storage_buffer_binding_size,
            max_buffer_size: al.max_buffer_size,
            // gpu::display's target is a texture of the film's size (the
            // downlevel default allows 2048 texels a side).
            max_texture_dimension_2d: al.max_texture_dimension_2d,
            ..wgpu::Limits::downlevel_defaults()
        };
        let mut features = wgpu::Features::empty();
        if timestamps {
            features |= wgpu::Features::TIMESTAMP_QUERY;
        }
        let disk =
            cache_dir.is_some() && adapter.features().contains(wgpu::Features::PIPELINE_CACHE);
        if disk {
            features |= wgpu::Features::PIPELINE_CACHE;
        }
        let desc = wgpu::DeviceDescriptor {
            label: Some("twintrace"),
            required_features: features,
            required_limits: limits,
            ..Default::default()
        };
        let (device, queue) =
            pollster::block_on(adapter.request_device(&desc)).map_err(|e| GpuError::Device {
                adapter: summary.name.clone(),
                reason: e.to_string(),
            })?;
        let lost = Arc::new(Mutex::new(None));
        let lost2 = lost.clone();
        device.set_device_lost_callback(move |reason, msg| {
            *lost2.lock().unwrap_or_else(|p| p.into_inner()) = Some(format!("{reason:?}: {msg}"));
        });
        let uncaptured = Arc::new(Mutex::new(None));
        let uncaptured2 = uncaptured.clone();
        // The default handler panics; record the error and report it at
        // the next check instead.
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            let mut slot = uncaptured2.lock().unwrap_or_else(|p| p.into_inner());
            if slot.is_none() {
                *slot = Some(e.to_string());
            }
        }));
        let (disk_cache, warning) = match cache_dir {
            Some(dir) if disk => {
                crate::pipeline::cache::DiskCache::open(&device, &adapter.get_info(), dir)
            }
            _ => (None, None),
        };
        Ok(Self {
            device,
            queue,
            adapter: summary,
            is_software: software,
            timestamps,
            lost,
            uncaptured,
            pipelines: std::sync::atomic::AtomicU64::new(0),
            caches: crate::pipeline::cache::Caches::new(software),
            disk_cache,
            warnings: Mutex::new(warning.into_iter().collect()),
        })
    }

    /// The usage a buffer bound as [`crate::bindings::PARAMS`] needs on
    /// this device: as the binding's access on it
    /// ([`crate::bindings::Binding::access_on`]) says.
    pub fn params_usage(&self) -> wgpu::BufferUsages {
        match crate::bindings::PARAMS.access_on(self.is_software) {
            crate::bindings::Access::Uniform => wgpu::BufferUsages::UNIFORM,
            _ => wgpu::BufferUsages::STORAGE,
        }
    }

    /// Fails where a buffer of `needed` bytes, `what`, cannot be bound as
    /// one storage buffer on this device.
    pub fn check_binding_size(&self, what: &'static str, needed: u64) -> Result<(), GpuError> {
        let limit = self.device.limits().max_storage_buffer_binding_size;
        if needed > limit {
            return Err(GpuError::TooLarge {
                adapter: self.adapter.name.clone(),
                what,
                needed,
                limit,
            });
        }
        Ok(())
    }

    /// Shader modules and pipelines the device's caches hold now (they
    /// are bounded: `gpu::pipeline`).
    pub fn cached_kernels(&self) -> (usize, usize) {
        self.caches.held()
    }

    /// Warnings for the user since the last call (a pipeline cache that
    /// could not be used or written), each one line.
    pub fn take_warnings(&self) -> Vec<String> {
        std::mem::take(&mut *self.warnings.lock().unwrap_or_else(|p| p.into_inner()))
    }

    /// The on-disk pipeline cache's file and the bytes loaded from it when
    /// the device opened, where the device has one.
    pub fn pipeline_cache(&self) -> Option<(&std::path::Path, usize)> {
        self.disk_cache.as_ref().map(|d| (d.path(), d.loaded))
    }

    /// Writes the pipeline cache to its file now (it is also written when
    /// the context is dropped).
    pub fn save_pipeline_cache(&self) -> Result<(), GpuError> {
        match &self.disk_cache {
            Some(d) => d.save().map_err(|e| {
                GpuError::Validation(format!(
                    "pipeline cache {}: cannot write it: {e}",
                    d.path().display()
                ))
            }),
            None => Ok(()),
        }
    }

    /// Compute pipelines created on this device so far: a progressive
    /// render's ranges must add none.
    pub fn pipelines_built(&self) -> u64 {
        self.pipelines.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Pipelines built and the time spent building them.
    pub fn compile_stats(&self) -> crate::pipeline::cache::CompileStats {
        let (module_time, pipeline_time) = self.caches.times();
        crate::pipeline::cache::CompileStats {
            pipelines: self.pipelines_built(),
            module_time,
            pipeline_time,
        }
    }

    pub(crate) fn count_pipelines(&self, n: usize) {
        self.pipelines
            .fetch_add(n as u64, std::sync::atomic::Ordering::Relaxed);
    }

    /// Fails if the device was lost or an error went unreported.
    pub fn check(&self) -> Result<(), GpuError> {
        if let Some(m) = self.lost.lock().unwrap_or_else(|p| p.into_inner()).clone() {
            return Err(GpuError::DeviceLost(m));
        }
        if let Some(m) = self
            .uncaptured
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
        {
            return Err(GpuError::Validation(m));
        }
        Ok(())
    }

    /// Waits for all submitted work.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::DeviceLost(e.to_string()))?;
        self.check()
    }

    /// Blocks until `submission` has run (later ones may still run).
    pub fn wait_for(&self, submission: wgpu::SubmissionIndex) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(submission),
                timeout: None,
            })
            .map_err(|e| GpuError::DeviceLost(e.to_string()))?;
        self.check()
    }
}

impl Drop for GpuContext {
    /// Writes the pipeline cache back; a failure costs only the next
    /// run's compile time, so it is not reported here (the CLI saves
    /// explicitly and reports).
    fn drop(&mut self) {
        if let Some(d) = &self.disk_cache {
            let _ = d.save();
        }
    }
}
