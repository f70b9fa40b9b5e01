//! The cases of the performance suites.
//!
//! - `quick` (seconds on two cores; what the regression self-test and a
//!   development loop run): error curves of four fixture scenes against
//!   the gates' stored references (32x32 to 64x64), a small render's
//!   paths/s and incoherent rays/s on a 10^4-triangle mesh.
//! - `full` (the GPU machine; about a minute): error curves of every
//!   stored reference, the gates' and the performance suite's own larger
//!   ones (fixtures/refs/perf/), paths/s of the benchmark scenes at their
//!   benchmark sizes (rtow-final 1200x800 depth 50, Cornell 512x512,
//!   spheres-10k, the glTF mesh), and rays/s on meshes of 10^4 and 10^6
//!   triangles.
//!
//! The sample counts double from 1 up to a per-backend cap; the GPU's cap
//! is higher, so that its curve reaches the error the CPU's does and
//! further.

use crate::compare::gate::{workspace_root, RefSet, RefSpec, GATE_REFS, PERF_REFS};
use anyhow::{anyhow, bail, Result};
use std::path::PathBuf;

/// Which suite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Suite {
    Quick,
    Full,
}

impl Suite {
    pub fn name(self) -> &'static str {
        match self {
            Suite::Quick => "quick",
            Suite::Full => "full",
        }
    }

    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "quick" => Ok(Suite::Quick),
            "full" => Ok(Suite::Full),
            other => bail!("unknown suite `{other}` (quick or full)"),
        }
    }
}

/// The seed of every measured render. It must differ from the reference's
/// (all are blessed with seed 1): with the same seed a render's samples
/// would be the reference's first samples, and its error would look
/// smaller than it is.
pub const PERF_SEED: u32 = 7;

/// An error curve: a stored reference and the sample counts to measure.
#[derive(Clone, Debug)]
pub struct CurveCase {
    pub set: RefSet,
    pub spec: RefSpec,
    /// Highest spp on the CPU and on the GPU (powers of two).
    pub max_spp_cpu: u32,
    pub max_spp_gpu: u32,
}

impl CurveCase {
    /// 1, 2, 4, … up to the backend's cap.
    pub fn ladder(&self, gpu: bool) -> Vec<u32> {
        let cap = if gpu {
            self.max_spp_gpu
        } else {
            self.max_spp_cpu
        };
        std::iter::successors(Some(1u32), |&s| s.checked_mul(2))
            .take_while(|&s| s <= cap)
            .collect()
    }
}

/// A throughput workload.
#[derive(Clone, Debug, PartialEq)]
pub enum Workload {
    /// Paths/s of one render.
    Render {
        name: &'static str,
        /// A built-in scene name or a fixture path relative to the root.
        scene: &'static str,
        width: u32,
        height: u32,
        max_depth: u32,
        spp_cpu: u32,
        spp_gpu: u32,
    },
    /// Incoherent closest-hit rays/s on a torus of `2 · segments.0 ·
    /// segments.1` triangles.
    Rays {
        name: &'static str,
        segments: (u32, u32),
        rays: u32,
    },
}

impl Workload {
    pub fn name(&self) -> &'static str {
        match self {
            Workload::Render { name, .. } | Workload::Rays { name, .. } => name,
        }
    }
}

/// The gates' references the quick suite measures: a diffuse box with a
/// small light (the slowest to converge), every material kind, a mesh and
/// the textures.
const QUICK_REFS: [&str; 4] = ["cornell-boxes", "four-materials", "gltf-mesh", "textures"];

/// The curves of `suite`, with their references' manifest lines.
pub fn curves(suite: Suite) -> Result<Vec<CurveCase>> {
    let gates = GATE_REFS.read_manifest()?;
    let mut out = Vec::new();
    match suite {
        Suite::Quick => {
            for name in QUICK_REFS {
                let spec = gates
                    .iter()
                    .find(|s| s.name == name)
                    .ok_or_else(|| anyhow!("no reference `{name}` in {}", GATE_REFS.manifest))?;
                out.push(CurveCase {
                    set: GATE_REFS,
                    spec: spec.clone(),
                    max_spp_cpu: 64,
                    max_spp_gpu: 64,
                });
            }
        }
        Suite::Full => {
            for spec in gates {
                out.push(CurveCase {
                    set: GATE_REFS,
                    spec,
                    max_spp_cpu: 256,
                    max_spp_gpu: 4096,
                });
            }
            for spec in PERF_REFS.read_manifest()? {
                out.push(CurveCase {
                    set: PERF_REFS,
                    spec,
                    max_spp_cpu: 256,
                    max_spp_gpu: 4096,
                });
            }
        }
    }
    for c in &out {
        if c.spec.seed == PERF_SEED {
            bail!(
                "reference `{}` was rendered with seed {PERF_SEED}, the seed of the measured renders: re-bless it with another seed",
                c.spec.name
            );
        }
    }
    Ok(out)
}

/// The files `suite` reads, as far as they are known before it runs: the
/// manifests, each curve's reference EXR and provenance note, and the
/// scene files of the curves and workloads (built-in scenes have none;
/// what a scene file reads in turn is known once it is loaded). An output
/// of `twintrace perf run` may not name one of them. A manifest that
/// cannot be read lists what it can (the run then fails on it).
pub fn input_files(suite: Suite) -> Vec<PathBuf> {
    let root = workspace_root();
    let mut files = vec![root.join(GATE_REFS.manifest)];
    if suite == Suite::Full {
        files.push(root.join(PERF_REFS.manifest));
    }
    for case in curves(suite).unwrap_or_default() {
        let (exr, provenance) = case.set.paths(&case.spec.name);
        files.extend([exr, provenance, root.join(&case.spec.scene)]);
    }
    for w in workloads(suite) {
        if let Workload::Render { scene, .. } = w {
            files.push(root.join(scene));
        }
    }
    files.retain(|f| f.is_file());
    files
}

/// The throughput workloads of `suite`.
pub fn workloads(suite: Suite) -> Vec<Workload> {
    match suite {
        Suite::Quick => vec![
            Workload::Render {
                name: "cornell-128",
                scene: "fixtures/scenes/cornell-boxes.json",
                width: 128,
                height: 128,
                max_depth: 50,
                spp_cpu: 8,
                spp_gpu: 8,
            },
            Workload::Rays {
                name: "rays-torus-1e4",
                segments: (100, 50),
                rays: 1 << 18,
            },
        ],
        Suite::Full => vec![
            // The figures of docs/benchmarks.md and the outside anchors.
            Workload::Render {
                name: "rtow-final-1200x800",
                scene: "rtow-final",
                width: 1200,
                height: 800,
                max_depth: 50,
                spp_cpu: 2,
                spp_gpu: 10,
            },
            Workload::Render {
                name: "cornell-512",
                scene: "cornell",
                width: 512,
                height: 512,
                max_depth: 50,
                spp_cpu: 4,
                spp_gpu: 1024,
            },
            Workload::Render {
                name: "spheres-10k-800x450",
                scene: "spheres-10k",
                width: 800,
                height: 450,
                max_depth: 16,
                spp_cpu: 4,
                spp_gpu: 256,
            },
            Workload::Render {
                name: "gltf-mesh-400x300",
                scene: "fixtures/scenes/gltf-mesh.json",
                width: 400,
                height: 300,
                max_depth: 12,
                spp_cpu: 8,
                spp_gpu: 256,
            },
            Workload::Rays {
                name: "rays-torus-1e4",
                segments: (100, 50),
                rays: 1 << 20,
            },
            Workload::Rays {
                name: "rays-torus-1e6",
                segments: (1000, 500),
                rays: 1 << 20,
            },
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ladders_double_up_to_the_cap() {
        let c = CurveCase {
            set: GATE_REFS,
            spec: RefSpec {
                name: "x".into(),
                scene: "x".into(),
                width: 1,
                height: 1,
                spp: 1,
                seed: 1,
                max_depth: 1,
            },
            max_spp_cpu: 8,
            max_spp_gpu: 20,
        };
        assert_eq!(c.ladder(false), [1, 2, 4, 8]);
        assert_eq!(c.ladder(true), [1, 2, 4, 8, 16]);
    }

    #[test]
    fn every_suite_resolves_against_the_manifests() {
        for suite in [Suite::Quick, Suite::Full] {
            let cases = curves(suite).unwrap();
            assert!(!cases.is_empty());
            assert!(cases.iter().all(|c| c.spec.seed != PERF_SEED));
        }
        assert!(Suite::parse("slow").is_err());
    }
}
