//! Adapters and devices: choosing one, listing them, opening it with the
//! limits the kernels need, and turning wgpu's asynchronous errors
//! (validation, device loss) into `GpuError`s instead of panics.

use crate::error::GpuError;
use std::sync::{Arc, Mutex};

/// Storage buffers the render kernel binds (scene arrays + film).
pub const STORAGE_BUFFERS_NEEDED: u32 = 15;
/// Storage buffers requested when the adapter has them: the test kernels
/// bind two more (input, output) beside the scene, the wavefront's
/// wf_prepare three (paths, queues, dispatch arguments).
pub const STORAGE_BUFFERS_WANTED: u32 = crate::wavefront::STORAGE_BUFFERS_NEEDED;

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

fn instance() -> wgpu::Instance {
    wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env())
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
    let inst = instance();
    let native = pollster::block_on(inst.enumerate_adapters(wgpu::Backends::PRIMARY));
    if !native.is_empty() {
        return native;
    }
    pollster::block_on(inst.enumerate_adapters(wgpu::Backends::GL))
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

    /// Opens a device on `adapter`, if it can run the kernels.
    pub fn open(adapter: &wgpu::Adapter) -> Result<Self, GpuError> {
        let summary = summarize(adapter);
        let al = adapter.limits();
        if al.max_storage_buffers_per_shader_stage < STORAGE_BUFFERS_NEEDED {
            return Err(GpuError::UnsuitableAdapter {
                adapter: summary.name,
                reason: format!(
                    "it allows {} storage buffers per shader stage, the kernels need {STORAGE_BUFFERS_NEEDED}",
                    al.max_storage_buffers_per_shader_stage
                ),
            });
        }
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let limits = wgpu::Limits {
            max_storage_buffers_per_shader_stage: al
                .max_storage_buffers_per_shader_stage
                .min(STORAGE_BUFFERS_WANTED),
            max_storage_buffer_binding_size: al.max_storage_buffer_binding_size,
            max_buffer_size: al.max_buffer_size,
            ..wgpu::Limits::downlevel_defaults()
        };
        let desc = wgpu::DeviceDescriptor {
            label: Some("twintrace"),
            required_features: if timestamps {
                wgpu::Features::TIMESTAMP_QUERY
            } else {
                wgpu::Features::empty()
            },
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
        let is_software = adapter.get_info().device_type == wgpu::DeviceType::Cpu;
        Ok(Self {
            device,
            queue,
            adapter: summary,
            is_software,
            timestamps,
            lost,
            uncaptured,
        })
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
}
