//! Kernel compilation: WGSL programs into compute pipelines, with three
//! caches so that a kernel is built once.
//!
//! - **Modules**, per device: a program's text is parsed and validated by
//!   naga once ([`wgpu::ShaderModule`] per source text).
//! - **Pipelines**, per device: a pipeline is created once per program,
//!   entry point, override constants and bind group layouts. The layouts
//!   are shared per device too ([`layout`]), so the renderers of several
//!   scenes, which differ only in their constants, and the oracle kernels
//!   the variant gates build for every scene, find their pipelines built.
//! - **On disk**, across runs: where the adapter supports it
//!   (`wgpu::Features::PIPELINE_CACHE`: Vulkan), the driver's pipeline
//!   cache is loaded when a device opens and written back when it closes,
//!   in `<cache dir>/pipelines-<adapter key>.bin` ([`cache_dir`]). The
//!   file holds a header naming the adapter, driver and twintrace version
//!   and a checksum of the data; a corrupt or foreign file is ignored
//!   (a warning, [`crate::GpuContext::take_warnings`]) and replaced.
//!
//! None of them changes what a kernel computes: the cached pipeline is
//! the one the same inputs would build.
//!
//! The caches, and the file's format, are in [`cache`], which needs no
//! device context (the context holds them); this module compiles through
//! them.

use crate::bindings::Binding;
use crate::context::GpuContext;
use crate::error::GpuError;
use crate::variants::Checks;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

pub(crate) mod cache;
pub mod inspect;

pub use cache::{cache_dir, CompileStats};
use cache::{ModuleCell, PipelineKey};

/// The bind group layout of `group`, made once per device and `name`
/// (pipelines built over the same layout object are found in the cache).
pub fn layout(ctx: &GpuContext, name: &'static str, group: &[Binding]) -> wgpu::BindGroupLayout {
    let mut layouts = ctx.caches.layouts.lock().unwrap_or_else(|p| p.into_inner());
    layouts
        .entry(name)
        .or_insert_with(|| {
            let entries: Vec<_> = group
                .iter()
                .map(|b| b.layout_entry_on(ctx.is_software))
                .collect();
            ctx.device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some(name),
                    entries: &entries,
                })
        })
        .clone()
}

/// The bind group layout shared by the render kernel and the test kernels
/// ([`crate::bindings::scene_group`]).
pub fn scene_layout(ctx: &GpuContext) -> wgpu::BindGroupLayout {
    layout(ctx, "twintrace scene", &crate::bindings::scene_group())
}

/// Compiles a WGSL program and one entry point into a compute pipeline,
/// reporting compile and validation errors as `GpuError::Shader`.
pub fn compile(
    ctx: &GpuContext,
    source: &str,
    entry: &str,
    layouts: &[&wgpu::BindGroupLayout],
) -> Result<wgpu::ComputePipeline, GpuError> {
    compile_with(ctx, source, entry, layouts, &[])
}

/// [`compile`] with values for the program's pipeline-overridable
/// constants (`override NAME` in WGSL).
pub fn compile_with(
    ctx: &GpuContext,
    source: &str,
    entry: &str,
    layouts: &[&wgpu::BindGroupLayout],
    constants: &[(&str, f64)],
) -> Result<wgpu::ComputePipeline, GpuError> {
    compile_checked(ctx, Checks::Checked, source, entry, layouts, constants)
}

/// [`compile_with`] under the given runtime checks (the render kernels'
/// variant axis, [`Checks`]).
pub fn compile_checked(
    ctx: &GpuContext,
    checks: Checks,
    source: &str,
    entry: &str,
    layouts: &[&wgpu::BindGroupLayout],
    constants: &[(&str, f64)],
) -> Result<wgpu::ComputePipeline, GpuError> {
    let mut p = compile_entries(ctx, checks, source, &[(entry, layouts)], constants)?;
    Ok(p.remove(0))
}

/// One shader module under `checks`, a pipeline for each entry point with
/// its bind group layouts; each found in the device's caches where it was
/// built before.
pub fn compile_entries(
    ctx: &GpuContext,
    checks: Checks,
    source: &str,
    entries: &[(&str, &[&wgpu::BindGroupLayout])],
    constants: &[(&str, f64)],
) -> Result<Vec<wgpu::ComputePipeline>, GpuError> {
    let keys: Vec<PipelineKey> = entries
        .iter()
        .map(|(entry, layouts)| PipelineKey {
            checks,
            source: source.to_string(),
            entry: entry.to_string(),
            constants: constants
                .iter()
                .map(|(n, v)| (n.to_string(), v.to_bits()))
                .collect(),
            layouts: layouts.iter().map(|l| (*l).clone()).collect(),
        })
        .collect();
    let cached = |keys: &[PipelineKey]| {
        let mut cached = ctx
            .caches
            .pipelines
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        keys.iter()
            .map(|k| cached.get(k))
            .collect::<Option<Vec<_>>>()
    };
    if let Some(found) = cached(&keys) {
        return Ok(found);
    }
    // One thread builds a set of pipelines; the others that need it wait
    // and find it built (or, where its build failed, try their own).
    let lock = ctx
        .caches
        .building
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .entry(keys.clone())
        .or_default()
        .clone();
    let _building = lock.lock().unwrap_or_else(|p| p.into_inner());
    let built = match cached(&keys) {
        Some(found) => Ok(found),
        None => build_entries(ctx, checks, source, entries, constants, keys.clone()),
    };
    let mut building = ctx
        .caches
        .building
        .lock()
        .unwrap_or_else(|p| p.into_inner());
    // The last thread out forgets the lock (this one and the map hold it).
    if std::sync::Arc::strong_count(&lock) <= 2 {
        building.remove(&keys);
    }
    built
}

/// [`compile_entries`]'s build of pipelines not in the cache, put there.
fn build_entries(
    ctx: &GpuContext,
    checks: Checks,
    source: &str,
    entries: &[(&str, &[&wgpu::BindGroupLayout])],
    constants: &[(&str, f64)],
    keys: Vec<PipelineKey>,
) -> Result<Vec<wgpu::ComputePipeline>, GpuError> {
    let device = &ctx.device;
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let cell = {
        let mut modules = ctx.caches.modules.lock().unwrap_or_else(|p| p.into_inner());
        let key = (checks, source.to_string());
        match modules.get(&key) {
            Some(cell) => cell,
            None => {
                let cell = ModuleCell::default();
                modules.insert(key, cell.clone());
                cell
            }
        }
    };
    // Built outside the cache's lock: naga's parse and validation of one
    // program do not hold up the others'.
    let module = cell
        .get_or_init(|| {
            let start = Instant::now();
            let descriptor = wgpu::ShaderModuleDescriptor {
                label: entries.first().map(|e| e.0),
                source: wgpu::ShaderSource::Wgsl(crate::bindings::program_on(
                    source,
                    ctx.is_software,
                )),
            };
            let m = match checks {
                Checks::Checked => device.create_shader_module(descriptor),
                // SAFETY: wgpu's contract for these checks off is that no
                // loop of the program runs forever. Every loop of the
                // render kernels is bounded (ARCHITECTURE.md, "Trusted
                // kernels": counted loops, bisections, the BVH walk over a
                // tree the host checks, `crate::traversal::check_walk_order`), and
                // bounds checks stay on.
                Checks::Trusted => unsafe {
                    device.create_shader_module_trusted(descriptor, checks.runtime_checks())
                },
            };
            add_nanos(&ctx.caches.module_nanos, start);
            m
        })
        .clone();
    let start = Instant::now();
    ctx.count_pipelines(entries.len());
    let disk = ctx.disk_cache.as_ref().map(|d| &d.cache);
    let pipelines: Vec<wgpu::ComputePipeline> = entries
        .iter()
        .map(|(entry, layouts)| {
            let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(entry),
                bind_group_layouts: &layouts.iter().map(|l| Some(*l)).collect::<Vec<_>>(),
                immediate_size: 0,
            });
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pl),
                module: &module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants,
                    ..Default::default()
                },
                cache: disk,
            })
        })
        .collect();
    add_nanos(&ctx.caches.pipeline_nanos, start);
    if let Some(e) = pollster::block_on(scope.pop()) {
        // A program that failed is not kept.
        ctx.caches
            .modules
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .remove(&(checks, source.to_string()));
        return Err(GpuError::Shader(e.to_string()));
    }
    ctx.check()?;
    let mut cached = ctx
        .caches
        .pipelines
        .lock()
        .unwrap_or_else(|p| p.into_inner());
    for (k, p) in keys.into_iter().zip(&pipelines) {
        cached.insert(k, p.clone());
    }
    Ok(pipelines)
}

fn add_nanos(total: &AtomicU64, since: Instant) {
    let n = u64::try_from(since.elapsed().as_nanos()).unwrap_or(u64::MAX);
    total.fetch_add(n, Ordering::Relaxed);
}
