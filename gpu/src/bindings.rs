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
pub const FILM: Binding = Binding {
    group: 0,
    slot: 15,
    name: "film",
    // Word-major: gpu::records::film_words.
    wgsl_type: "array<u32>",
    access: Access::ReadWrite,
};

/// The scene's read-only arrays, in slot order.
pub const SCENE_ARRAYS: [Binding; 14] = [
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

/// Storage buffers wf_prepare's pipeline layout holds (scene group, wave
/// group, arguments): the wavefront needs an adapter with this many
/// (`gpu::wavefront::STORAGE_BUFFERS_NEEDED`), and a device is opened with
/// as many where its adapter has them (`gpu::context`).
pub const WAVEFRONT_STORAGE_BUFFERS: u32 = 18;

/// Storage buffers the path megakernel's layouts hold (scene group, wave
/// group; `gpu::wavefront::STORAGE_BUFFERS_NEEDED_PATHS`).
pub const PATH_MEGAKERNEL_STORAGE_BUFFERS: u32 = 17;

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
    /// The WGSL declaration.
    pub fn wgsl(&self) -> String {
        let space = match self.access {
            Access::Uniform => "uniform",
            Access::Read => "storage, read",
            Access::ReadWrite => "storage, read_write",
        };
        format!(
            "@group({}) @binding({}) var<{space}> {}: {};\n",
            self.group, self.slot, self.name, self.wgsl_type
        )
    }

    /// The bind group layout entry (compute stage).
    pub fn layout_entry(&self) -> wgpu::BindGroupLayoutEntry {
        let ty = match self.access {
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
}
