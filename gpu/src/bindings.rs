//! Every binding of the kernels, defined once: group, slot, WGSL name and
//! type, and access. The WGSL declarations (in shaders/generated.wgsl), the
//! bind group layouts and the bind groups are all derived from these
//! tables, so a slot is never typed twice.

/// How a kernel accesses a binding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    Uniform,
    Read,
    ReadWrite,
}

/// One `@group(g) @binding(s) var<…> name: ty;`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Binding {
    pub group: u32,
    pub slot: u32,
    pub name: &'static str,
    pub wgsl_type: &'static str,
    pub access: Access,
}

const fn scene(slot: u32, name: &'static str, wgsl_type: &'static str) -> Binding {
    Binding {
        group: 0,
        slot,
        name,
        wgsl_type,
        access: Access::Read,
    }
}

pub const PARAMS: Binding = Binding {
    group: 0,
    slot: 0,
    name: "params",
    wgsl_type: "GpuParams",
    access: Access::Uniform,
};
pub const NODES: Binding = scene(1, "nodes", "array<vec4<u32>>");
pub const LEAF_ENTRIES: Binding = scene(2, "leaf_entries", "array<vec4<u32>>");
pub const PRIMITIVES: Binding = scene(3, "primitives", "array<GpuPrimitive>");
pub const SPHERES: Binding = scene(4, "spheres", "array<GpuSphere>");
pub const QUADS: Binding = scene(5, "quads", "array<GpuQuad>");
pub const TRIANGLES: Binding = scene(6, "triangles", "array<GpuTriangle>");
pub const VERTICES: Binding = scene(7, "vertices", "array<GpuVertex>");
pub const MATERIALS: Binding = scene(8, "materials", "array<GpuMaterial>");
pub const TEXTURES: Binding = scene(9, "textures", "array<GpuTexture>");
pub const IMAGES: Binding = scene(10, "images", "array<GpuImage>");
pub const TEXELS: Binding = scene(11, "texels", "array<f32>");
pub const EMITTERS: Binding = scene(12, "emitters", "array<GpuEmitter>");
pub const LIGHT_DENSITIES: Binding = scene(13, "light_densities", "array<GpuLightDensity>");
pub const VERTEX_EXTRAS: Binding = scene(14, "vertex_extras", "array<GpuVertexExtra>");
pub const QUADRICS: Binding = scene(15, "quadrics", "array<GpuQuadric>");
pub const FILM: Binding = Binding {
    group: 0,
    slot: 16,
    name: "film",
    // Word-major: gpu::records::film_words.
    wgsl_type: "array<u32>",
    access: Access::ReadWrite,
};

/// The scene's read-only arrays, in slot order.
pub const SCENE_ARRAYS: [Binding; 15] = [
    NODES,
    LEAF_ENTRIES,
    PRIMITIVES,
    SPHERES,
    QUADS,
    TRIANGLES,
    VERTICES,
    MATERIALS,
    TEXTURES,
    IMAGES,
    TEXELS,
    EMITTERS,
    LIGHT_DENSITIES,
    VERTEX_EXTRAS,
    QUADRICS,
];

/// Group 0, shared by the render kernel and the test kernels.
pub fn scene_group() -> Vec<Binding> {
    let mut all = vec![PARAMS];
    all.extend(SCENE_ARRAYS);
    all.push(FILM);
    all
}

/// Group 1 of the test kernels (`gpu::testing`).
pub const TEST_INPUT: Binding = Binding {
    group: 1,
    slot: 0,
    name: "input",
    wgsl_type: "array<u32>",
    access: Access::Read,
};
pub const TEST_OUTPUT: Binding = Binding {
    group: 1,
    slot: 1,
    name: "output",
    wgsl_type: "array<u32>",
    access: Access::ReadWrite,
};
pub const TEST_IO_GROUP: [Binding; 2] = [TEST_INPUT, TEST_OUTPUT];

/// Group 1 of the wavefront kernels (`gpu::wavefront`): every path slot's
/// state, and the queues of live paths and of rays to trace.
pub const PATHS: Binding = Binding {
    group: 1,
    slot: 0,
    name: "paths",
    wgsl_type: "array<u32>",
    access: Access::ReadWrite,
};
pub const WAVE_QUEUES: Binding = Binding {
    group: 1,
    slot: 1,
    name: "wave_queues",
    wgsl_type: "WaveQueues",
    access: Access::ReadWrite,
};
pub const WAVE_GROUP: [Binding; 2] = [PATHS, WAVE_QUEUES];

/// Group 2, bound for wf_prepare alone: the indirect dispatch arguments
/// it writes for the next wf_extend and wf_shade.
pub const WAVE_ARGS: Binding = Binding {
    group: 2,
    slot: 0,
    name: "wave_args",
    wgsl_type: "WaveArgs",
    access: Access::ReadWrite,
};

/// Storage buffers wf_prepare's pipeline layout holds on a device of
/// that kind (scene group, wave group, arguments): the wavefront needs an
/// adapter with this many (`gpu::wavefront::Pipelines::new`), and a
/// device is opened with as many where its adapter has them
/// (`gpu::context`).
pub fn wavefront_storage_buffers(software: bool) -> u32 {
    storage_buffers_on(&[&scene_group(), &WAVE_GROUP, &[WAVE_ARGS]], software)
}

/// Storage buffers the path megakernel's layouts hold on a device of
/// that kind (scene group, wave group).
pub fn path_megakernel_storage_buffers(software: bool) -> u32 {
    storage_buffers_on(&[&scene_group(), &WAVE_GROUP], software)
}

/// Storage buffers the render kernel's layout holds on a device of that
/// kind (the scene group: scene arrays and film, and the params where
/// they are a storage buffer).
pub fn render_storage_buffers(software: bool) -> u32 {
    storage_buffers_on(&[&scene_group()], software)
}

/// The film's image layers the layers kernel writes (`gpu::film`).
pub const FILM_LAYERS: Binding = Binding {
    group: 1,
    slot: 0,
    name: "layers",
    wgsl_type: "array<u32>",
    access: Access::ReadWrite,
};

/// Group 1 of the film merge kernel (`gpu::film::merge_film`): a band of
/// another film's words (band-major: word `w` of the band's pixel `i` at
/// `w · len + i`) and the band, `(first pixel, len, 0, 0)`.
pub const MERGE_IN: Binding = Binding {
    group: 1,
    slot: 0,
    name: "merge_in",
    wgsl_type: "array<u32>",
    access: Access::Read,
};
pub const MERGE_BAND: Binding = Binding {
    group: 1,
    slot: 1,
    name: "merge_band",
    wgsl_type: "vec4<u32>",
    access: Access::Uniform,
};
pub const MERGE_GROUP: [Binding; 2] = [MERGE_IN, MERGE_BAND];

impl Binding {
    /// How a device of that kind binds it: as its table says, except
    /// [`PARAMS`] on a software adapter, a read-only storage buffer
    /// ([`params_in_storage`]).
    pub fn access_on(&self, software: bool) -> Access {
        if params_in_storage(software) && *self == PARAMS {
            Access::Read
        } else {
            self.access
        }
    }

    /// The WGSL declaration.
    pub fn wgsl(&self) -> String {
        self.wgsl_as(self.access)
    }

    fn wgsl_as(&self, access: Access) -> String {
        let space = match access {
            Access::Uniform => "uniform",
            Access::Read => "storage, read",
            Access::ReadWrite => "storage, read_write",
        };
        format!(
            "@group({}) @binding({}) var<{space}> {}: {};\n",
            self.group, self.slot, self.name, self.wgsl_type
        )
    }

    /// The bind group layout entry (compute stage) on a device of that
    /// kind ([`Self::access_on`]).
    pub fn layout_entry_on(&self, software: bool) -> wgpu::BindGroupLayoutEntry {
        let ty = match self.access_on(software) {
            Access::Uniform => wgpu::BufferBindingType::Uniform,
            Access::Read => wgpu::BufferBindingType::Storage { read_only: true },
            Access::ReadWrite => wgpu::BufferBindingType::Storage { read_only: false },
        };
        wgpu::BindGroupLayoutEntry {
            binding: self.slot,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }
    }
}

/// The WGSL declarations of a group.
pub fn wgsl_declarations(group: &[Binding]) -> String {
    group.iter().map(Binding::wgsl).collect()
}

/// Whether a device binds [`PARAMS`] as a read-only storage buffer
/// rather than a uniform buffer: on a software adapter. Lavapipe (Mesa
/// 22.3, Debian 12's) specializes a kernel on the values it reads from a
/// uniform buffer and, with no cache of those variants, re-runs its NIR
/// passes and compiles again at every dispatch of a large kernel (the
/// render kernels): 40–110 ms a dispatch, most of the per-pixel
/// megakernel's time there. It does nothing of the kind with storage
/// buffers ([`program_on`] has each kernel copy the params first). On
/// hardware the uniform buffer stays: as a storage buffer the H200 took
/// 0.3–5 % longer (docs/benchmarks.md, "Software Vulkan (lavapipe)").
pub fn params_in_storage(software: bool) -> bool {
    software
}

/// The storage buffers a layout of `group`s holds on a device of that
/// kind: one more with [`params_in_storage`] where it binds [`PARAMS`].
fn storage_buffers_on(groups: &[&[Binding]], software: bool) -> u32 {
    groups
        .iter()
        .flat_map(|g| g.iter())
        .filter(|b| b.access_on(software) != Access::Uniform)
        .count() as u32
}

/// `source` as a device of that kind compiles it. Where
/// [`params_in_storage`], the generated declaration of [`PARAMS`] becomes
/// a read-only storage buffer, `params_storage`, and a private copy,
/// `params`, that each entry point fills first: the kernels read the
/// copy as they read the uniform buffer elsewhere (a storage buffer read
/// at every use made lavapipe's compiles of the large kernels about a
/// fifth longer). Else, and in a program without the declaration,
/// `source` unchanged.
pub fn program_on(source: &str, software: bool) -> std::borrow::Cow<'_, str> {
    let uniform = PARAMS.wgsl();
    if !params_in_storage(software) || !source.contains(&uniform) {
        return source.into();
    }
    let storage = Binding {
        name: PARAMS_STORAGE,
        access: Access::Read,
        ..PARAMS
    };
    let declared = source.replacen(
        &uniform,
        &format!(
            "{}var<private> {}: {};\n",
            storage.wgsl(),
            PARAMS.name,
            PARAMS.wgsl_type
        ),
        1,
    );
    // Each entry point's body (the first brace after its `fn`: a
    // parameter list holds none) starts with the copy.
    let copy = format!("\n    {} = {PARAMS_STORAGE};", PARAMS.name);
    let mut out = String::with_capacity(declared.len() + 64);
    let mut rest = declared.as_str();
    while let Some(at) = rest.find("@compute") {
        let body = rest[at..]
            .find("fn ")
            .and_then(|f| rest[at + f..].find('{').map(|b| at + f + b + 1));
        let Some(body) = body else { break };
        out.push_str(&rest[..body]);
        out.push_str(&copy);
        rest = &rest[body..];
    }
    out.push_str(rest);
    out.into()
}

/// The storage buffer's name in a program [`program_on`] rewrote.
const PARAMS_STORAGE: &str = "params_storage";

#[cfg(test)]
mod tests {
    use super::*;

    /// Slots within a group are 0, 1, 2, … in table order, and names are
    /// unique across the groups a test kernel sees together.
    #[test]
    fn slots_are_dense_and_names_unique() {
        for group in [
            scene_group(),
            TEST_IO_GROUP.to_vec(),
            WAVE_GROUP.to_vec(),
            vec![WAVE_ARGS],
            MERGE_GROUP.to_vec(),
        ] {
            for (i, b) in group.iter().enumerate() {
                assert_eq!(b.slot, i as u32, "{}", b.name);
                assert_eq!(b.group, group[0].group, "{}", b.name);
            }
        }
        let mut names: Vec<_> = scene_group()
            .iter()
            .chain(&TEST_IO_GROUP)
            .chain(&WAVE_GROUP)
            .chain([&WAVE_ARGS])
            .chain(&MERGE_GROUP)
            .map(|b| b.name)
            .collect();
        names.sort_unstable();
        let n = names.len();
        names.dedup();
        assert_eq!(names.len(), n);
    }

    /// On a software adapter the params block alone moves to the storage
    /// address space, in the layouts and in the program text alike; on
    /// hardware nothing changes.
    #[test]
    fn the_params_are_a_storage_buffer_on_a_software_adapter_only() {
        // The generated declarations and two entry points (the render
        // programs themselves run on lavapipe in every GPU test).
        let source = format!(
            "{}\n@compute @workgroup_size(64)\nfn a(@builtin(global_invocation_id) gid: vec3<u32>) {{\n    film[gid.x] = params.width;\n}}\n\n@compute @workgroup_size(8, 8, 1)\nfn b() {{\n    film[0] = params.height;\n}}\n",
            wgsl_declarations(&scene_group())
        );
        assert_eq!(program_on(&source, false), source);
        let software = program_on(&source, true);
        assert_eq!(software.matches(&PARAMS.wgsl()).count(), 0);
        let declared = "@group(0) @binding(0) var<storage, read> params_storage: GpuParams;\nvar<private> params: GpuParams;\n";
        assert_eq!(software.matches(declared).count(), 1);
        // Every entry point copies the params first, and nothing else
        // changed.
        let entries = source.matches("@compute").count();
        assert_eq!(entries, 2);
        let copy = "\n    params = params_storage;";
        assert_eq!(software.matches(copy).count(), entries);
        assert_eq!(
            software.replace(copy, "").replace(declared, &PARAMS.wgsl()),
            source
        );
        for at in software.match_indices("@compute").map(|(i, _)| i) {
            let body = at + software[at..].find('{').unwrap() + 1;
            assert!(
                software[body..].starts_with(copy),
                "{}",
                &software[at..body]
            );
        }
        // A program without the declaration is left alone.
        assert_eq!(program_on("fn f() {}", true), "fn f() {}");
        let ty = |b: &Binding, software| match b.layout_entry_on(software).ty {
            wgpu::BindingType::Buffer { ty, .. } => ty,
            other => panic!("{}: {other:?}", b.name),
        };
        assert_eq!(ty(&PARAMS, false), wgpu::BufferBindingType::Uniform);
        assert_eq!(
            ty(&PARAMS, true),
            wgpu::BufferBindingType::Storage { read_only: true }
        );
        for b in scene_group().iter().skip(1).chain(&MERGE_GROUP) {
            assert_eq!(ty(b, true), ty(b, false), "{}", b.name);
        }
        // The storage buffers a device must allow: one more on software.
        assert_eq!(
            (
                render_storage_buffers(false),
                path_megakernel_storage_buffers(false),
                wavefront_storage_buffers(false)
            ),
            (16, 18, 19)
        );
        assert_eq!(
            (
                render_storage_buffers(true),
                path_megakernel_storage_buffers(true),
                wavefront_storage_buffers(true)
            ),
            (17, 19, 20)
        );
    }
}
