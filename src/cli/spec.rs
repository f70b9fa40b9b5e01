//! The render spec's command-line options: clap reads the library's own
//! types ([`gpu::Variant`]'s axes, the estimator, the tone map) through
//! [`axis`], with their defaults taken from [`RenderSpec::DEFAULT`], so
//! the defaults are defined once and there are no mirror enums.

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::Args;
use reference::integrator::Integrator;
use twintrace::render::RenderSpec;
use twintrace::tonemap::Tonemap;

/// A value type of the spec named on the command line: every value with
/// its name and a line of help.
pub trait Axis: Copy + Send + Sync + 'static {
    fn values() -> &'static [Self];
    fn name(self) -> &'static str;
    fn help(self) -> &'static str;
}

/// The clap parser of an [`Axis`]: its names are the possible values
/// (listed in `--help`, refused with clap's one-line error otherwise).
pub fn axis<T: Axis>() -> impl TypedValueParser<Value = T> {
    PossibleValuesParser::new(
        T::values()
            .iter()
            .map(|v| PossibleValue::new(v.name()).help(v.help())),
    )
    .map(|name: String| {
        // The parser above admits only these names, so one matches.
        T::values()
            .iter()
            .copied()
            .find(|v| v.name() == name)
            .unwrap_or(T::values()[0])
    })
}

impl Axis for Integrator {
    fn values() -> &'static [Self] {
        &Integrator::ALL
    }
    fn name(self) -> &'static str {
        Integrator::name(self)
    }
    fn help(self) -> &'static str {
        match self {
            Integrator::Bsdf => "BSDF sampling only",
            Integrator::Mis => {
                "light sampling and BSDF sampling combined by multiple importance sampling"
            }
        }
    }
}

impl Axis for gpu::Kernel {
    fn values() -> &'static [Self] {
        &[gpu::Kernel::Specialized, gpu::Kernel::General]
    }
    fn name(self) -> &'static str {
        match self {
            gpu::Kernel::Specialized => "specialized",
            gpu::Kernel::General => "general",
        }
    }
    fn help(self) -> &'static str {
        match self {
            gpu::Kernel::Specialized => {
                "built without the code of the features the scene does not use"
            }
            gpu::Kernel::General => "every feature's code (the same image bit for bit)",
        }
    }
}

impl Axis for gpu::Schedule {
    fn values() -> &'static [Self] {
        &gpu::Schedule::ALL
    }
    fn name(self) -> &'static str {
        gpu::Schedule::name(self)
    }
    fn help(self) -> &'static str {
        match self {
            gpu::Schedule::Megakernel => "one invocation traces a pixel's paths to the end",
            gpu::Schedule::Wavefront(gpu::PathLayout::Aos, gpu::ShadeOrder::Queue) => {
                "kernels per stage over queues of live paths, path state as an array of structs"
            }
            gpu::Schedule::Wavefront(gpu::PathLayout::Soa, gpu::ShadeOrder::Queue) => {
                "the wavefront with path state as a structure of arrays"
            }
            gpu::Schedule::Wavefront(gpu::PathLayout::Aos, gpu::ShadeOrder::Material) => {
                "the wavefront with each bounce's paths sorted by the material they hit"
            }
            gpu::Schedule::Wavefront(gpu::PathLayout::Soa, gpu::ShadeOrder::Material) => {
                "the sorted wavefront with path state as a structure of arrays"
            }
            gpu::Schedule::PathMegakernel => {
                "one invocation a path of a wave, the film folded after: fills the GPU at any size"
            }
        }
    }
}

impl Axis for gpu::Traversal {
    fn values() -> &'static [Self] {
        &gpu::Traversal::ALL
    }
    fn name(self) -> &'static str {
        gpu::Traversal::name(self)
    }
    fn help(self) -> &'static str {
        match self {
            gpu::Traversal::Binary => "the reference's binary BVH",
            gpu::Traversal::Wide => "the same tree, four children a node",
            gpu::Traversal::Compressed => {
                "the same tree, eight children a node, their boxes quantized to 8 bits"
            }
            gpu::Traversal::BruteForce => "every primitive tested (tiny scenes)",
        }
    }
}

impl Axis for gpu::LeafLayout {
    fn values() -> &'static [Self] {
        &gpu::LeafLayout::ALL
    }
    fn name(self) -> &'static str {
        gpu::LeafLayout::name(self)
    }
    fn help(self) -> &'static str {
        match self {
            gpu::LeafLayout::Indexed => "primitive ids: a test reads the primitive's record",
            gpu::LeafLayout::Inline => "each entry a 64-byte copy of what its test reads",
            gpu::LeafLayout::InlineSoa => "the inline entries as a structure of arrays",
        }
    }
}

impl Axis for gpu::NodeLayout {
    fn values() -> &'static [Self] {
        &gpu::NodeLayout::ALL
    }
    fn name(self) -> &'static str {
        gpu::NodeLayout::name(self)
    }
    fn help(self) -> &'static str {
        match self {
            gpu::NodeLayout::Aos => "a record's two 16-byte words side by side",
            gpu::NodeLayout::Soa => "every record's first word, then every second",
        }
    }
}

impl Axis for gpu::Dispatch {
    fn values() -> &'static [Self] {
        &gpu::Dispatch::ALL
    }
    fn name(self) -> &'static str {
        gpu::Dispatch::name(self)
    }
    fn help(self) -> &'static str {
        match self {
            gpu::Dispatch::Switch => "a switch on the tag",
            gpu::Dispatch::Branches => "a chain of tag tests",
        }
    }
}

impl Axis for gpu::Checks {
    fn values() -> &'static [Self] {
        &gpu::Checks::ALL
    }
    fn name(self) -> &'static str {
        gpu::Checks::name(self)
    }
    fn help(self) -> &'static str {
        match self {
            gpu::Checks::Trusted => "bounds checks, no loop bounding (every loop ends)",
            gpu::Checks::Checked => "wgpu's default: bounds checks and bounded loops",
        }
    }
}

const DEFAULT: RenderSpec = RenderSpec::DEFAULT;

/// The estimator and the display transform: what a user sets.
#[derive(Clone, Copy, Debug, Args)]
pub struct LookArgs {
    /// The estimator, on either backend.
    #[arg(long, value_parser = axis::<Integrator>(), default_value = DEFAULT.variant.integrator.name())]
    pub integrator: Integrator,
    /// Display transform for the PNG (the EXR is always linear).
    #[arg(long, value_enum, default_value_t = DEFAULT.tonemap)]
    pub tonemap: Tonemap,
}

/// The GPU variant axes: for developers. Every value renders the same
/// image (bit for bit, or a few ulp apart where a driver contracts
/// arithmetic differently); they differ in speed.
#[derive(Clone, Copy, Debug, Args)]
#[command(next_help_heading = "GPU variant (for developers; every value renders the same image)")]
pub struct VariantArgs {
    /// The GPU's render kernel.
    #[arg(long, value_parser = axis::<gpu::Kernel>(), default_value = Axis::name(DEFAULT.variant.kernel))]
    pub kernel: gpu::Kernel,
    /// How the GPU schedules the paths.
    #[arg(long, value_parser = axis::<gpu::Schedule>(), default_value = DEFAULT.variant.schedule.name())]
    pub schedule: gpu::Schedule,
    /// How the GPU walks the scene.
    #[arg(long, value_parser = axis::<gpu::Traversal>(), default_value = DEFAULT.variant.traversal.name())]
    pub traversal: gpu::Traversal,
    /// How the GPU's BVH leaves hold their primitives.
    #[arg(long, value_parser = axis::<gpu::LeafLayout>(), default_value = DEFAULT.variant.leaves.name())]
    pub leaves: gpu::LeafLayout,
    /// How the GPU's BVH node records are laid out.
    #[arg(long, value_parser = axis::<gpu::NodeLayout>(), default_value = DEFAULT.variant.nodes.name())]
    pub nodes: gpu::NodeLayout,
    /// How the GPU kernel picks a primitive's and a material's code from their tags.
    #[arg(long, value_parser = axis::<gpu::Dispatch>(), default_value = DEFAULT.variant.dispatch.name())]
    pub dispatch: gpu::Dispatch,
    /// What wgpu checks while the GPU's render kernel runs.
    #[arg(long, value_parser = axis::<gpu::Checks>(), default_value = DEFAULT.variant.checks.name())]
    pub checks: gpu::Checks,
}

/// The spec these options give.
pub fn spec(look: &LookArgs, variant: &VariantArgs) -> RenderSpec {
    RenderSpec {
        variant: gpu::Variant {
            integrator: look.integrator,
            kernel: variant.kernel,
            schedule: variant.schedule,
            traversal: variant.traversal,
            nodes: variant.nodes,
            leaves: variant.leaves,
            dispatch: variant.dispatch,
            checks: variant.checks,
        },
        tonemap: look.tonemap,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Debug, Parser)]
    struct Probe {
        #[command(flatten)]
        look: LookArgs,
        #[command(flatten)]
        variant: VariantArgs,
    }

    #[test]
    fn no_options_give_the_one_default_spec() {
        let p = Probe::try_parse_from(["probe"]).unwrap();
        assert_eq!(spec(&p.look, &p.variant), RenderSpec::DEFAULT);
    }

    #[test]
    fn every_value_of_every_axis_parses_to_itself() {
        fn each<T: Axis + PartialEq + std::fmt::Debug>(flag: &str, get: fn(&RenderSpec) -> T) {
            for &v in T::values() {
                let p = Probe::try_parse_from(["probe", flag, v.name()]).unwrap();
                assert_eq!(get(&spec(&p.look, &p.variant)), v, "{flag} {}", v.name());
            }
            assert!(Probe::try_parse_from(["probe", flag, "no-such-value"]).is_err());
        }
        each("--integrator", |s| s.variant.integrator);
        each("--kernel", |s| s.variant.kernel);
        each("--schedule", |s| s.variant.schedule);
        each("--traversal", |s| s.variant.traversal);
        each("--leaves", |s| s.variant.leaves);
        each("--nodes", |s| s.variant.nodes);
        each("--dispatch", |s| s.variant.dispatch);
        each("--checks", |s| s.variant.checks);
    }
}
