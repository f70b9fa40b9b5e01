//! The axes a GPU render varies along (issue: GPU variants): the walk
//! ([`Traversal`]), how the nodes and the leaves are laid out
//! ([`NodeLayout`], [`LeafLayout`]), how a tag selects its code
//! ([`Dispatch`]), the kernel's specialization ([`Kernel`]), how the paths
//! are scheduled ([`Schedule`], [`PathLayout`]), what wgpu checks at run
//! time ([`Checks`]), and the [`Variant`] that
//! names one point of them all, with the pipeline-overridable constants
//! that carry each axis to the kernels. Only the axes are here: what each
//! builds lives with it (the walks' records in `traversal`, the feature
//! sets in `features`, the wave kernels in `wavefront`), and those modules
//! re-export their axis from here.

/// The render program's pipeline-overridable constant that picks the walk
/// ([`Traversal::tag`]).
pub const TRAVERSAL_CONSTANT: &str = "TRAVERSAL";

/// [`TRAVERSAL_CONSTANT`] of the binary walk (also brute force's: one
/// leaf).
pub const TRAVERSAL_BINARY: u32 = 0;

/// [`TRAVERSAL_CONSTANT`] of the four-wide walk.
pub const TRAVERSAL_WIDE: u32 = 1;

/// [`TRAVERSAL_CONSTANT`] of the compressed eight-wide walk.
pub const TRAVERSAL_COMPRESSED: u32 = 2;

/// How a render walks the scene.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Traversal {
    /// The reference's binary tree, near child first, one explicit stack
    /// (the baseline, the oracle of the others).
    #[default]
    Binary,
    /// The same tree collapsed four children to a node
    /// (`traversal::wide_records`).
    Wide,
    /// The same tree collapsed eight children to a node, the children's
    /// boxes quantized to 8 bits a bound relative to the node and rounded
    /// outward (`compressed::compress`; Ylitie, Karras and Laine 2017).
    Compressed,
    /// Every primitive tested, in id order: the binary walk over one leaf
    /// that holds them all (for tiny scenes, and as the plainest oracle).
    BruteForce,
}

impl Traversal {
    /// Every walk, the baseline first.
    pub const ALL: [Traversal; 4] = [
        Traversal::Binary,
        Traversal::Wide,
        Traversal::Compressed,
        Traversal::BruteForce,
    ];

    /// The CLI's and perf's name.
    pub fn name(self) -> &'static str {
        match self {
            Traversal::Binary => "bvh2",
            Traversal::Wide => "bvh4",
            Traversal::Compressed => "cwbvh8",
            Traversal::BruteForce => "brute",
        }
    }

    /// The value of [`TRAVERSAL_CONSTANT`] for this walk.
    pub fn tag(self) -> u32 {
        match self {
            Traversal::Binary | Traversal::BruteForce => TRAVERSAL_BINARY,
            Traversal::Wide => TRAVERSAL_WIDE,
            Traversal::Compressed => TRAVERSAL_COMPRESSED,
        }
    }
}

/// How a walk's leaves name what they hold (`leaf_entries`, one entry per
/// position of the tree's primitive order).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum LeafLayout {
    /// The primitive's id, four to a `vec4<u32>`: a test reads the
    /// `primitives` record, then the shape's (sphere, quad, or triangle
    /// and its three vertices): two to four dependent reads (the
    /// baseline).
    #[default]
    Indexed,
    /// A 64-byte record in leaf order with what the test reads: the id
    /// and kind, the admits box, the shape's nine floats (sphere centre
    /// and radius; quad corner, u, v; triangle's three vertex positions),
    /// copied from the same packed records: one read per test, the same
    /// bits (`scene_buffers::inline_entries`).
    Inline,
    /// The inline entries as a structure of arrays: every entry's first
    /// 16-byte word, then every entry's second, third and fourth
    /// (`traversal::soa_entries`).
    InlineSoa,
}

impl LeafLayout {
    pub const ALL: [LeafLayout; 3] = [
        LeafLayout::Indexed,
        LeafLayout::Inline,
        LeafLayout::InlineSoa,
    ];

    /// The CLI's and perf's name.
    pub fn name(self) -> &'static str {
        match self {
            LeafLayout::Indexed => "indexed",
            LeafLayout::Inline => "inline",
            LeafLayout::InlineSoa => "inline-soa",
        }
    }

    /// The value of [`LEAVES_CONSTANT`].
    pub fn tag(self) -> u32 {
        match self {
            LeafLayout::Indexed => LEAVES_INDEXED,
            LeafLayout::Inline => LEAVES_INLINE,
            LeafLayout::InlineSoa => LEAVES_INLINE_SOA,
        }
    }
}

/// The render program's pipeline-overridable constant that picks the leaf
/// layout ([`LeafLayout::tag`]).
pub const LEAVES_CONSTANT: &str = "LEAVES";

/// [`LEAVES_CONSTANT`] of [`LeafLayout::Indexed`].
pub const LEAVES_INDEXED: u32 = 0;

/// [`LEAVES_CONSTANT`] of [`LeafLayout::Inline`].
pub const LEAVES_INLINE: u32 = 1;

/// [`LEAVES_CONSTANT`] of [`LeafLayout::InlineSoa`].
pub const LEAVES_INLINE_SOA: u32 = 2;

/// How the `nodes` binding holds the walk's records: each
/// [`BvhNode`](reference::bvh::BvhNode) is two `vec4<u32>` words (box
/// minimum and `index`; box maximum and `meta`), each compressed node
/// of [`Traversal::Compressed`] five (`gpu::compressed`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum NodeLayout {
    /// A record's words side by side (array of structs).
    #[default]
    Aos,
    /// Every record's first word, then every record's second, and so on
    /// (structure of arrays).
    Soa,
}

impl NodeLayout {
    /// Both layouts, the baseline first.
    pub const ALL: [NodeLayout; 2] = [NodeLayout::Aos, NodeLayout::Soa];

    /// The CLI's and perf's name.
    pub fn name(self) -> &'static str {
        match self {
            NodeLayout::Aos => "aos",
            NodeLayout::Soa => "soa",
        }
    }

    /// The value of [`NODE_LAYOUT_CONSTANT`].
    pub fn tag(self) -> u32 {
        match self {
            NodeLayout::Aos => NODE_LAYOUT_AOS,
            NodeLayout::Soa => NODE_LAYOUT_SOA,
        }
    }
}

/// The render program's pipeline-overridable constant that picks the node
/// layout ([`NodeLayout::tag`]).
pub const NODE_LAYOUT_CONSTANT: &str = "NODE_LAYOUT";

/// [`NODE_LAYOUT_CONSTANT`] of [`NodeLayout::Aos`].
pub const NODE_LAYOUT_AOS: u32 = 0;

/// [`NODE_LAYOUT_CONSTANT`] of [`NodeLayout::Soa`].
pub const NODE_LAYOUT_SOA: u32 = 1;

/// The render program's pipeline-overridable constant that picks how a
/// tag selects its code ([`Dispatch::tag`]).
pub const DISPATCH_CONSTANT: &str = "DISPATCH";

/// [`DISPATCH_CONSTANT`] of [`Dispatch::Switch`].
pub const DISPATCH_SWITCH: u32 = 0;

/// [`DISPATCH_CONSTANT`] of [`Dispatch::Branches`].
pub const DISPATCH_BRANCHES: u32 = 1;

/// How a tag selects its code where the kernel has both ways written (the
/// primitive's intersection, the material's sampling): WGSL has no
/// virtual calls, and these are its two stand-ins.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Dispatch {
    /// A `switch` on the tag (the baseline).
    #[default]
    Switch,
    /// A chain of `if tag == …` tests, one per kind, in a fixed order.
    Branches,
}

impl Dispatch {
    pub const ALL: [Dispatch; 2] = [Dispatch::Switch, Dispatch::Branches];

    /// The CLI's and perf's name.
    pub fn name(self) -> &'static str {
        match self {
            Dispatch::Switch => "switch",
            Dispatch::Branches => "branches",
        }
    }

    /// The value of [`DISPATCH_CONSTANT`].
    pub fn tag(self) -> u32 {
        match self {
            Dispatch::Switch => DISPATCH_SWITCH,
            Dispatch::Branches => DISPATCH_BRANCHES,
        }
    }
}

/// Which kernel a render compiles (the feature set each is built for:
/// `Kernel::features`, in `features`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Kernel {
    /// Specialized to the scene's `Features` (the default).
    #[default]
    Specialized,
    /// Every feature's code (the oracle of the specialized kernel).
    General,
}

/// How the wavefront stores a path's state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum PathLayout {
    /// Array of structs: a path's words together (the baseline).
    #[default]
    Aos,
    /// Structure of arrays: each field's words of every path together.
    Soa,
}

/// The order in which the wavefront's shade kernel takes a bounce's live
/// paths.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ShadeOrder {
    /// As the queue holds them: the order the last shade appended them in
    /// (the baseline).
    #[default]
    Queue,
    /// Bucketed by the material their ray hit (`GpuMaterial::shade_bucket`:
    /// materials of one kind together, then by index; misses and paths
    /// with only a shadow ray last) by a counting sort before every shade,
    /// so that a workgroup runs one material's code over one material's
    /// textures. Each path computes what it computes in any order, and the
    /// film folds its samples in sample order: the film is the unsorted
    /// wavefront's, bit for bit.
    Material,
}

/// How a render's paths are scheduled on the GPU.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Schedule {
    /// One invocation traces a pixel's paths to the end (the baseline, the
    /// oracle of the wavefront).
    #[default]
    Megakernel,
    /// Kernels per stage over queues of live paths.
    Wavefront(PathLayout, ShadeOrder),
    /// One invocation per path of a wave (pixel × sample) traces it to the
    /// end, as the megakernel's loop body does, and the wavefront's
    /// accumulate kernel folds the paths' light into the film in sample
    /// order: the megakernel's code with the parallelism of the
    /// wavefront's waves (a 256x256 image is 65,536 megakernel invocations,
    /// a quarter of what an H100 holds resident).
    PathMegakernel,
}

impl Schedule {
    /// Every schedule, for the tests and the CLI.
    pub const ALL: [Schedule; 6] = [
        Schedule::Megakernel,
        Self::WAVES[0],
        Self::WAVES[1],
        Self::WAVES[2],
        Self::WAVES[3],
        Self::WAVES[4],
    ];

    /// The schedules other than the megakernel, which is their oracle.
    pub const WAVES: [Schedule; 5] = [
        Schedule::Wavefront(PathLayout::Aos, ShadeOrder::Queue),
        Schedule::Wavefront(PathLayout::Soa, ShadeOrder::Queue),
        Schedule::PathMegakernel,
        Schedule::Wavefront(PathLayout::Aos, ShadeOrder::Material),
        Schedule::Wavefront(PathLayout::Soa, ShadeOrder::Material),
    ];

    /// The CLI's and perf's name.
    pub fn name(self) -> &'static str {
        match self {
            Schedule::Megakernel => "megakernel",
            Schedule::Wavefront(PathLayout::Aos, ShadeOrder::Queue) => "wavefront",
            Schedule::Wavefront(PathLayout::Soa, ShadeOrder::Queue) => "wavefront-soa",
            Schedule::Wavefront(PathLayout::Aos, ShadeOrder::Material) => "wavefront-sorted",
            Schedule::Wavefront(PathLayout::Soa, ShadeOrder::Material) => "wavefront-soa-sorted",
            Schedule::PathMegakernel => "megakernel-paths",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// What wgpu adds to the render kernels at run time
/// (`wgpu::ShaderRuntimeChecks`). Both keep the bounds checks (without them
/// the H200 measured nothing more, docs/benchmarks.md); they differ in the
/// loop bounding wgpu writes into every loop so that a driver may not
/// assume the loop ends. The kernel's results are the same bits either
/// way (`twintrace::twins::checks` holds the trusted films to the checked
/// ones); trusted needs every loop of the program to end, which
/// ARCHITECTURE.md ("Trusted kernels") argues and
/// `traversal::check_walk_order` checks of the records the walk follows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Checks {
    /// Bounds checks on, loops bounded by wgpu (wgpu's default).
    Checked,
    /// Bounds checks and integer division guards on, no loop bounding.
    #[default]
    Trusted,
}

impl Checks {
    pub const ALL: [Checks; 2] = [Checks::Trusted, Checks::Checked];

    /// The CLI's and perf's name.
    pub fn name(self) -> &'static str {
        match self {
            Checks::Checked => "checked",
            Checks::Trusted => "trusted",
        }
    }

    /// What wgpu is told to add.
    pub fn runtime_checks(self) -> wgpu::ShaderRuntimeChecks {
        match self {
            Checks::Checked => wgpu::ShaderRuntimeChecks::checked(),
            Checks::Trusted => wgpu::ShaderRuntimeChecks {
                bounds_checks: true,
                force_loop_bounding: false,
                ..wgpu::ShaderRuntimeChecks::checked()
            },
        }
    }
}

/// A GPU renderer variant: estimator, kernel specialization, schedule and
/// walk, named for the perf tables (`megakernel`,
/// `wavefront-soa-mis-general`, `megakernel-paths-bvh4`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Variant {
    pub integrator: reference::integrator::Integrator,
    pub kernel: Kernel,
    pub schedule: Schedule,
    pub traversal: Traversal,
    pub nodes: NodeLayout,
    pub leaves: LeafLayout,
    pub dispatch: Dispatch,
    pub checks: Checks,
}

impl Default for Variant {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Variant {
    /// The variant a render runs unless told otherwise: the CLI's,
    /// `perf`'s and `selftest`'s default, defined here only. MIS; the
    /// kernel specialized to the scene; one invocation a path
    /// ([`Schedule::PathMegakernel`]: fills the GPU at any image size);
    /// the binary walk over array-of-structs nodes; inline leaf entries
    /// (1.03-1.2x on an H100, docs/benchmarks.md); switch dispatch.
    pub const DEFAULT: Variant = Variant {
        integrator: reference::integrator::Integrator::Mis,
        kernel: Kernel::Specialized,
        schedule: Schedule::PathMegakernel,
        traversal: Traversal::Binary,
        nodes: NodeLayout::Aos,
        leaves: LeafLayout::Inline,
        dispatch: Dispatch::Switch,
        checks: Checks::Trusted,
    };

    /// `schedule` running `integrator` in its plain form: the kernel
    /// specialized to the scene, the binary walk over array-of-structs
    /// nodes and indexed leaves, switch dispatch.
    pub fn plain(integrator: reference::integrator::Integrator, schedule: Schedule) -> Self {
        Variant {
            integrator,
            kernel: Kernel::Specialized,
            schedule,
            traversal: Traversal::Binary,
            nodes: NodeLayout::Aos,
            leaves: LeafLayout::Indexed,
            dispatch: Dispatch::Switch,
            checks: Checks::Trusted,
        }
    }

    /// `<schedule>[-mis][-general][-<walk>][-nodes-soa][-inline[-soa]][-branches][-checked]`,
    /// the binary walk, array-of-structs nodes, indexed leaves, switch
    /// dispatch and trusted kernels unnamed.
    pub fn name(self) -> String {
        let mut s = self.schedule.name().to_string();
        if self.integrator == reference::integrator::Integrator::Mis {
            s += "-mis";
        }
        if self.kernel == Kernel::General {
            s += "-general";
        }
        if self.traversal != Traversal::Binary {
            s += "-";
            s += self.traversal.name();
        }
        if self.nodes != NodeLayout::Aos {
            // `-soa` alone names the wavefront's path state.
            s += "-nodes-";
            s += self.nodes.name();
        }
        if self.leaves != LeafLayout::Indexed {
            s += "-";
            s += self.leaves.name();
        }
        if self.dispatch != Dispatch::Switch {
            s += "-";
            s += self.dispatch.name();
        }
        if self.checks != Checks::Trusted {
            s += "-";
            s += self.checks.name();
        }
        s
    }

    /// Every variant, the megakernel's first.
    pub fn all() -> Vec<Variant> {
        let mut out = Vec::new();
        for checks in Checks::ALL {
            for dispatch in Dispatch::ALL {
                for leaves in LeafLayout::ALL {
                    for nodes in NodeLayout::ALL {
                        for traversal in Traversal::ALL {
                            for schedule in Schedule::ALL {
                                for kernel in [Kernel::Specialized, Kernel::General] {
                                    for integrator in reference::integrator::Integrator::ALL {
                                        out.push(Variant {
                                            integrator,
                                            kernel,
                                            schedule,
                                            traversal,
                                            nodes,
                                            leaves,
                                            dispatch,
                                            checks,
                                        });
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        out
    }

    pub fn from_name(name: &str) -> Option<Variant> {
        Self::all().into_iter().find(|v| v.name() == name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn variant_names_are_unique() {
        let mut names: Vec<String> = Variant::all().iter().map(|v| v.name()).collect();
        assert!(names.contains(&"megakernel-mis-general".to_string()));
        assert!(names.contains(&"wavefront-soa-mis".to_string()));
        let n = names.len();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), n);
        assert!(names.contains(&"megakernel-paths-mis-bvh4".to_string()));
        assert!(names.contains(&"megakernel-paths-bvh4-inline".to_string()));
        assert!(names.contains(&"wavefront-soa-bvh4-nodes-soa-inline".to_string()));
        assert!(names.contains(&"megakernel-paths-mis-inline-branches".to_string()));
        assert!(names.contains(&"megakernel-paths-inline-soa".to_string()));
        assert!(names.contains(&"megakernel-paths-mis-cwbvh8-inline".to_string()));
        // 6 schedules, 2 kernels, 2 estimators, 4 walks, 2 node layouts,
        // 3 leaf layouts, 2 dispatches, 2 runtime checks.
        assert_eq!(n, 2304);
        assert!(names.contains(&"wavefront-soa-sorted-mis-inline".to_string()));
        assert!(names.contains(&"megakernel-paths-mis-inline-checked".to_string()));
    }

    #[test]
    fn schedule_names_round_trip() {
        for s in Schedule::ALL {
            assert_eq!(Schedule::from_name(s.name()), Some(s));
        }
        assert_eq!(Schedule::from_name("wavefront-aos"), None);
    }
}
