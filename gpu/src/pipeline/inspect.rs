//! What the driver made of each kernel: its pipeline executables'
//! statistics (registers, local memory or spills, shared memory, as the
//! driver names them) and internal representations, through
//! `VK_KHR_pipeline_executable_properties`, and the SPIR-V that was handed
//! to the driver.
//!
//! wgpu builds its pipelines without the flags that make a driver keep
//! these, and opens its device without the extension. So each kernel a
//! device has built (the keys of its pipeline cache) is built again, for
//! inspection only, on a second Vulkan device of the same physical device
//! and instance, opened with the extension and the robustness features
//! wgpu enables (they change the machine code): the same WGSL through the
//! same naga, with the options wgpu-hal's Vulkan backend sets
//! (`wgpu_hal::vulkan::Adapter`'s `naga_options`, with the kernel's
//! runtime checks) and the override constants applied as wgpu applies
//! them. The descriptor set layouts come from the module's bindings. The
//! pipeline inspected is therefore the production kernel compiled by the
//! same driver from the same SPIR-V, not the very object rendered with.
//!
//! Nothing here runs a kernel or changes one: renders are the same bits
//! whether or not they are inspected.

use super::cache::PipelineKey;
use crate::context::GpuContext;
use crate::error::GpuError;
use crate::variants::Checks;
use ash::vk;
use std::ffi::c_char;

/// One kernel as the driver reports it.
#[derive(Clone, Debug)]
pub struct KernelReport {
    /// The entry point.
    pub entry: String,
    pub checks: Checks,
    /// The SPIR-V handed to the driver.
    pub spirv: Vec<u32>,
    /// The pipeline's executables (a compute pipeline has one; a driver
    /// may report more).
    pub executables: Vec<Executable>,
}

/// One executable of a pipeline.
#[derive(Clone, Debug)]
pub struct Executable {
    pub name: String,
    pub description: String,
    /// The subgroup size it was compiled for (0: not reported).
    pub subgroup_size: u32,
    pub statistics: Vec<Statistic>,
    /// The driver's internal representations (name, text), when asked for.
    pub representations: Vec<(String, String)>,
}

/// One statistic of an executable, as the driver names it.
#[derive(Clone, Debug, PartialEq)]
pub struct Statistic {
    pub name: String,
    pub description: String,
    pub value: StatValue,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StatValue {
    Bool(bool),
    Int(i64),
    Uint(u64),
    Float(f64),
}

impl std::fmt::Display for StatValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StatValue::Bool(b) => write!(f, "{b}"),
            StatValue::Int(v) => write!(f, "{v}"),
            StatValue::Uint(v) => write!(f, "{v}"),
            StatValue::Float(v) => write!(f, "{v}"),
        }
    }
}

impl KernelReport {
    /// One line: the entry point, its checks, and each executable's
    /// statistics (`name value`, as the driver names them).
    pub fn line(&self) -> String {
        let mut s = format!("{} ({})", self.entry, self.checks.name());
        for e in &self.executables {
            s += &format!(": {}", e.name);
            if e.subgroup_size != 0 {
                s += &format!(", subgroup {}", e.subgroup_size);
            }
            for st in &e.statistics {
                s += &format!(", {} {}", st.name, st.value);
            }
            if e.statistics.is_empty() {
                s += ", no statistics reported";
            }
        }
        s
    }
}

/// Why a device cannot be inspected: not Vulkan, or a driver without the
/// extension.
fn unavailable(ctx: &GpuContext, why: &str) -> GpuError {
    GpuError::NoInspection {
        adapter: ctx.adapter.name.clone(),
        reason: why.to_string(),
    }
}

/// What [`kernels`] found: each kernel's SPIR-V, and what the driver
/// says of it unless it cannot say (`unavailable`, one line).
#[derive(Clone, Debug)]
pub struct Inspection {
    pub kernels: Vec<KernelReport>,
    pub unavailable: Option<String>,
}

impl Inspection {
    /// One line a kernel ([`KernelReport::line`]), or the one line saying
    /// why the driver cannot report.
    pub fn lines(&self) -> Vec<String> {
        match &self.unavailable {
            Some(why) => vec![why.clone()],
            None => self
                .kernels
                .iter()
                .map(|k| format!("kernel {}", k.line()))
                .collect(),
        }
    }
}

/// Every kernel `ctx` has built and still holds (its pipeline cache's
/// keys, the most recently used first), built again for inspection;
/// `representations` also asks for the driver's internal representations.
/// A device whose driver lacks the extension still gets each kernel's
/// SPIR-V, with the reason in [`Inspection::unavailable`]; a device that
/// is not Vulkan is an error.
pub fn kernels(ctx: &GpuContext, representations: bool) -> Result<Inspection, GpuError> {
    let keys: Vec<PipelineKey> = ctx
        .caches
        .pipelines
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .keys_by_use()
        .into_iter()
        .cloned()
        .collect();
    // SAFETY: the handles are used only while `hal` (and so wgpu's
    // device, instance and physical device) is alive, and the second
    // device made from them is destroyed before it is dropped.
    unsafe {
        let hal = ctx
            .device
            .as_hal::<wgpu::hal::api::Vulkan>()
            .ok_or_else(|| unavailable(ctx, "its backend is not Vulkan"))?;
        let instance = hal.shared_instance().raw_instance();
        let physical = hal.raw_physical_device();
        let target = Target::of(instance, physical);
        let inspector = if keys.is_empty() {
            Ok(None)
        } else {
            Inspector::open(ctx, instance, physical, &target).map(Some)
        };
        let mut out = Inspection {
            kernels: Vec::with_capacity(keys.len()),
            unavailable: None,
        };
        match inspector {
            Ok(None) => {}
            Ok(Some(i)) => {
                let reports: Result<Vec<_>, _> = keys
                    .iter()
                    .map(|k| i.inspect(ctx, k, &target, representations))
                    .collect();
                i.close();
                out.kernels = reports?;
            }
            Err(e) => {
                out.unavailable = Some(e.to_string());
                for k in &keys {
                    let (spirv, _) = k.spirv(ctx, &target)?;
                    out.kernels.push(KernelReport {
                        entry: k.entry.clone(),
                        checks: k.checks,
                        spirv,
                        executables: Vec::new(),
                    });
                }
            }
        }
        Ok(out)
    }
}

/// What the SPIR-V is written for: the device's Vulkan version and
/// whether wgpu enabled `robustBufferAccess2` on it.
struct Target {
    api_version: u32,
    robust_buffer_access2: bool,
    has_robustness2: bool,
}

impl Target {
    /// # Safety
    /// `instance` and `physical` must be valid.
    unsafe fn of(instance: &ash::Instance, physical: vk::PhysicalDevice) -> Target {
        let properties = instance.get_physical_device_properties(physical);
        let has_robustness2 = instance
            .enumerate_device_extension_properties(physical)
            .unwrap_or_default()
            .iter()
            .any(|e| {
                e.extension_name_as_c_str()
                    .is_ok_and(|n| n == ash::ext::robustness2::NAME)
            });
        let mut robustness2 = vk::PhysicalDeviceRobustness2FeaturesEXT::default();
        // vkGetPhysicalDeviceFeatures2 is Vulkan 1.1's.
        if has_robustness2 && properties.api_version >= vk::API_VERSION_1_1 {
            let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut robustness2);
            instance.get_physical_device_features2(physical, &mut features2);
        }
        Target {
            api_version: properties.api_version,
            robust_buffer_access2: robustness2.robust_buffer_access2 == vk::TRUE,
            has_robustness2,
        }
    }
}

impl PipelineKey {
    fn spirv(
        &self,
        ctx: &GpuContext,
        target: &Target,
    ) -> Result<(Vec<u32>, naga::Module), GpuError> {
        spirv(
            &self.source,
            ctx.is_software,
            self.checks,
            &self.entry,
            &self.constants,
            target.api_version,
            target.robust_buffer_access2,
        )
    }
}

/// The SPIR-V wgpu's Vulkan backend hands the driver for `entry` of
/// `source` (with `PARAMS` moved to storage on a software adapter, as the
/// kernels are built there) under `checks` and the override `constants`,
/// for a device of Vulkan `api_version` with or without
/// `robustBufferAccess2`.
pub fn spirv(
    source: &str,
    software: bool,
    checks: Checks,
    entry: &str,
    constants: &[(String, u64)],
    api_version: u32,
    robust_buffer_access2: bool,
) -> Result<(Vec<u32>, naga::Module), GpuError> {
    let program = crate::bindings::program_on(source, software);
    let module = naga::front::wgsl::parse_str(&program)
        .map_err(|e| GpuError::Shader(e.emit_to_string(&program)))?;
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .map_err(|e| GpuError::Shader(e.emit_to_string(&program)))?;
    let constants: naga::back::PipelineConstants = constants
        .iter()
        .map(|(n, bits)| (n.clone(), f64::from_bits(*bits)))
        .collect();
    let (module, info) = naga::back::pipeline_constants::process_overrides(
        &module,
        &info,
        Some((naga::ShaderStage::Compute, entry)),
        &constants,
    )
    .map_err(|e| GpuError::Shader(format!("{entry}: {e}")))?;
    let runtime = checks.runtime_checks();
    let unchecked = naga::proc::BoundsCheckPolicy::Unchecked;
    let restrict = naga::proc::BoundsCheckPolicy::Restrict;
    let mut options = naga::back::spv::Options {
        // wgpu-hal: the highest SPIR-V the device's Vulkan version takes.
        lang_version: match api_version {
            v if v >= vk::API_VERSION_1_3 => (1, 6),
            v if v >= vk::API_VERSION_1_2 => (1, 5),
            v if v >= vk::API_VERSION_1_1 => (1, 3),
            _ => (1, 0),
        },
        flags: naga::back::spv::WriterFlags::FORCE_POINT_SIZE
            | naga::back::spv::WriterFlags::LABEL_VARYINGS,
        capabilities: None,
        bounds_check_policies: naga::proc::BoundsCheckPolicies {
            index: restrict,
            buffer: if robust_buffer_access2 {
                unchecked
            } else {
                restrict
            },
            image_load: restrict,
            binding_array: unchecked,
        },
        // wgpu-hal zeroes workgroup memory natively where the device
        // enables it; the inspection device does not, so the polyfill.
        zero_initialize_workgroup_memory:
            naga::back::spv::ZeroInitializeWorkgroupMemoryMode::Polyfill,
        force_loop_bounding: runtime.force_loop_bounding,
        ray_query_initialization_tracking: runtime.ray_query_initialization_tracking,
        ..Default::default()
    };
    if !runtime.bounds_checks {
        options.bounds_check_policies = naga::proc::BoundsCheckPolicies {
            index: unchecked,
            buffer: unchecked,
            image_load: unchecked,
            binding_array: unchecked,
        };
    }
    options.emit_int_div_checks = runtime.int_div_checks;
    let pipeline = naga::back::spv::PipelineOptions {
        shader_stage: naga::ShaderStage::Compute,
        entry_point: entry.to_string(),
    };
    let words = naga::back::spv::write_vec(&module, &info, &options, Some(&pipeline))
        .map_err(|e| GpuError::Shader(format!("{entry}: SPIR-V: {e}")))?;
    Ok((words, module.into_owned()))
}

/// The second device, opened for inspection.
struct Inspector {
    device: ash::Device,
    executables: ash::khr::pipeline_executable_properties::Device,
}

impl Inspector {
    /// # Safety
    /// `instance` and `physical` must be alive until [`Self::close`].
    unsafe fn open(
        ctx: &GpuContext,
        instance: &ash::Instance,
        physical: vk::PhysicalDevice,
        target: &Target,
    ) -> Result<Self, GpuError> {
        let name = ash::khr::pipeline_executable_properties::NAME;
        let extensions = instance
            .enumerate_device_extension_properties(physical)
            .map_err(|e| unavailable(ctx, &format!("cannot list its extensions ({e})")))?;
        if !extensions
            .iter()
            .any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == name))
        {
            return Err(unavailable(
                ctx,
                "its driver lacks VK_KHR_pipeline_executable_properties",
            ));
        }
        if target.api_version < vk::API_VERSION_1_1 {
            return Err(unavailable(ctx, "its Vulkan is 1.0"));
        }
        let mut exec = vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default();
        {
            let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut exec);
            instance.get_physical_device_features2(physical, &mut features2);
        }
        if exec.pipeline_executable_info == vk::FALSE {
            return Err(unavailable(
                ctx,
                "its driver does not offer pipelineExecutableInfo",
            ));
        }
        // The robustness wgpu asks for where the device has it (it
        // changes the machine code).
        let core = instance.get_physical_device_features(physical);
        let families = instance.get_physical_device_queue_family_properties(physical);
        let family = families
            .iter()
            .position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE))
            .ok_or_else(|| unavailable(ctx, "it has no compute queue"))?;
        let priorities = [1.0f32];
        let queues = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(family as u32)
            .queue_priorities(&priorities)];
        let mut names = vec![name.as_ptr()];
        let mut want_exec = vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default()
            .pipeline_executable_info(true);
        let mut want_robustness2 = vk::PhysicalDeviceRobustness2FeaturesEXT::default()
            .robust_buffer_access2(target.robust_buffer_access2);
        let enabled = vk::PhysicalDeviceFeatures::default()
            .robust_buffer_access(core.robust_buffer_access == vk::TRUE);
        let mut info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queues)
            .enabled_features(&enabled)
            .push_next(&mut want_exec);
        if target.has_robustness2 && target.robust_buffer_access2 {
            names.push(ash::ext::robustness2::NAME.as_ptr());
            info = info.push_next(&mut want_robustness2);
        }
        let info = info.enabled_extension_names(&names);
        let device = instance
            .create_device(physical, &info, None)
            .map_err(|e| unavailable(ctx, &format!("its inspection device did not open ({e})")))?;
        let executables = ash::khr::pipeline_executable_properties::Device::new(instance, &device);
        Ok(Inspector {
            device,
            executables,
        })
    }

    unsafe fn close(self) {
        self.device.destroy_device(None);
    }

    /// Builds the kernel of `key` with the capture flags and reads what
    /// the driver says of it.
    unsafe fn inspect(
        &self,
        ctx: &GpuContext,
        key: &PipelineKey,
        target: &Target,
        representations: bool,
    ) -> Result<KernelReport, GpuError> {
        let (spirv, module) = key.spirv(ctx, target)?;
        let d = &self.device;
        let vk_err =
            |what: &str, e: vk::Result| GpuError::Validation(format!("{}: {what}: {e}", key.entry));
        let shader = d
            .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&spirv), None)
            .map_err(|e| vk_err("shader module", e))?;
        let mut sets = Vec::new();
        for bindings in set_bindings(&module) {
            match d.create_descriptor_set_layout(
                &vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings),
                None,
            ) {
                Ok(l) => sets.push(l),
                Err(e) => {
                    self.destroy(shader, &sets, None, None);
                    return Err(vk_err("descriptor set layout", e));
                }
            }
        }
        let layout = match d.create_pipeline_layout(
            &vk::PipelineLayoutCreateInfo::default().set_layouts(&sets),
            None,
        ) {
            Ok(l) => l,
            Err(e) => {
                self.destroy(shader, &sets, None, None);
                return Err(vk_err("pipeline layout", e));
            }
        };
        let entry = std::ffi::CString::new(key.entry.as_str())
            .map_err(|_| GpuError::Validation(format!("{}: not a C string", key.entry)))?;
        let mut flags = vk::PipelineCreateFlags::CAPTURE_STATISTICS_KHR;
        if representations {
            flags |= vk::PipelineCreateFlags::CAPTURE_INTERNAL_REPRESENTATIONS_KHR;
        }
        let info = vk::ComputePipelineCreateInfo::default()
            .flags(flags)
            .stage(
                vk::PipelineShaderStageCreateInfo::default()
                    .stage(vk::ShaderStageFlags::COMPUTE)
                    .module(shader)
                    .name(&entry),
            )
            .layout(layout);
        let pipeline = match d.create_compute_pipelines(vk::PipelineCache::null(), &[info], None) {
            Ok(p) => p[0],
            Err((_, e)) => {
                self.destroy(shader, &sets, Some(layout), None);
                return Err(vk_err("pipeline", e));
            }
        };
        let read = self.read(pipeline, representations);
        self.destroy(shader, &sets, Some(layout), Some(pipeline));
        Ok(KernelReport {
            entry: key.entry.clone(),
            checks: key.checks,
            spirv,
            executables: read.map_err(|e| vk_err("executables", e))?,
        })
    }

    unsafe fn read(
        &self,
        pipeline: vk::Pipeline,
        representations: bool,
    ) -> Result<Vec<Executable>, vk::Result> {
        let x = &self.executables;
        let props = x.get_pipeline_executable_properties(
            &vk::PipelineInfoKHR::default().pipeline(pipeline),
        )?;
        let mut out = Vec::new();
        for (i, p) in props.iter().enumerate() {
            let info = vk::PipelineExecutableInfoKHR::default()
                .pipeline(pipeline)
                .executable_index(i as u32);
            let statistics = x
                .get_pipeline_executable_statistics(&info)?
                .iter()
                .map(|s| Statistic {
                    name: text(&s.name),
                    description: text(&s.description),
                    value: match s.format {
                        vk::PipelineExecutableStatisticFormatKHR::BOOL32 => {
                            StatValue::Bool(s.value.b32 != 0)
                        }
                        vk::PipelineExecutableStatisticFormatKHR::INT64 => {
                            StatValue::Int(s.value.i64)
                        }
                        vk::PipelineExecutableStatisticFormatKHR::FLOAT64 => {
                            StatValue::Float(s.value.f64)
                        }
                        _ => StatValue::Uint(s.value.u64),
                    },
                })
                .collect();
            let representations = if representations {
                self.representations(&info)?
            } else {
                Vec::new()
            };
            out.push(Executable {
                name: text(&p.name),
                description: text(&p.description),
                subgroup_size: p.subgroup_size,
                statistics,
                representations,
            });
        }
        Ok(out)
    }

    /// The executable's internal representations: sizes first, then the
    /// data (ash's reader asks for the sizes only).
    unsafe fn representations(
        &self,
        info: &vk::PipelineExecutableInfoKHR<'_>,
    ) -> Result<Vec<(String, String)>, vk::Result> {
        let fp = self.executables.fp();
        let device = self.device.handle();
        let get =
            |count: &mut u32, reps: *mut vk::PipelineExecutableInternalRepresentationKHR<'_>| {
                (fp.get_pipeline_executable_internal_representations_khr)(device, info, count, reps)
                    .result()
            };
        let mut count = 0u32;
        get(&mut count, std::ptr::null_mut())?;
        let mut reps =
            vec![vk::PipelineExecutableInternalRepresentationKHR::default(); count as usize];
        get(&mut count, reps.as_mut_ptr())?;
        let mut data: Vec<Vec<u8>> = reps.iter().map(|r| vec![0u8; r.data_size]).collect();
        for (r, buf) in reps.iter_mut().zip(&mut data) {
            r.p_data = buf.as_mut_ptr().cast();
        }
        get(&mut count, reps.as_mut_ptr())?;
        Ok(reps
            .iter()
            .zip(data)
            .map(|(r, bytes)| {
                let body = if r.is_text == vk::TRUE {
                    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
                    String::from_utf8_lossy(&bytes[..end]).into_owned()
                } else {
                    format!("({} bytes of binary data)", bytes.len())
                };
                (text(&r.name), body)
            })
            .collect())
    }

    unsafe fn destroy(
        &self,
        shader: vk::ShaderModule,
        sets: &[vk::DescriptorSetLayout],
        layout: Option<vk::PipelineLayout>,
        pipeline: Option<vk::Pipeline>,
    ) {
        let d = &self.device;
        if let Some(p) = pipeline {
            d.destroy_pipeline(p, None);
        }
        if let Some(l) = layout {
            d.destroy_pipeline_layout(l, None);
        }
        for &s in sets {
            d.destroy_descriptor_set_layout(s, None);
        }
        d.destroy_shader_module(shader, None);
    }
}

/// A fixed-size C string of a Vulkan structure.
fn text(chars: &[c_char]) -> String {
    let bytes: Vec<u8> = chars
        .iter()
        .take_while(|&&c| c != 0)
        .map(|&c| c as u8)
        .collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Each descriptor set's bindings, as the module declares them (sets 0..
/// up to the highest group; a group without bindings is an empty set).
fn set_bindings(module: &naga::Module) -> Vec<Vec<vk::DescriptorSetLayoutBinding<'static>>> {
    let mut sets: Vec<Vec<vk::DescriptorSetLayoutBinding<'static>>> = Vec::new();
    for (_, var) in module.global_variables.iter() {
        let Some(binding) = &var.binding else {
            continue;
        };
        let kind = match var.space {
            naga::AddressSpace::Uniform => vk::DescriptorType::UNIFORM_BUFFER,
            naga::AddressSpace::Storage { .. } => vk::DescriptorType::STORAGE_BUFFER,
            naga::AddressSpace::Handle => match &module.types[var.ty].inner {
                naga::TypeInner::Sampler { .. } => vk::DescriptorType::SAMPLER,
                naga::TypeInner::Image {
                    class: naga::ImageClass::Storage { .. },
                    ..
                } => vk::DescriptorType::STORAGE_IMAGE,
                _ => vk::DescriptorType::SAMPLED_IMAGE,
            },
            _ => continue,
        };
        let group = binding.group as usize;
        if sets.len() <= group {
            sets.resize_with(group + 1, Vec::new);
        }
        sets[group].push(
            vk::DescriptorSetLayoutBinding::default()
                .binding(binding.binding)
                .descriptor_type(kind)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::COMPUTE),
        );
    }
    sets
}
