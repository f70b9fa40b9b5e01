//! `twintrace mitsuba-tests --data DIR`: Mitsuba 3's render tests (the
//! scenes of a mitsuba-data checkout) on the twins, one line a scene and
//! twin: PASS or FAIL by Mitsuba's protocol with its figures and the image
//! sums', or REFUSED with the plugin the reader does not implement
//! ([`twintrace::mitsuba_tests`]).

use super::common::{choose_device, Backend};
use anyhow::{bail, Result};
use clap::Args;
use std::path::PathBuf;
use twintrace::mitsuba_tests::{self, Budget, Outcome};
use twintrace::render::Devices;

#[derive(Debug, Args)]
pub struct MitsubaTestsArgs {
    /// A checkout of mitsuba-data (its tests/scenes are run; nothing of it is copied).
    #[arg(long)]
    pub data: PathBuf,
    /// The twins to run, in order (cpu, gpu).
    #[arg(long, value_delimiter = ',', default_values = ["cpu", "gpu"])]
    pub backend: Vec<Backend>,
    /// Only the scenes whose name (folder/file) contains this.
    #[arg(long)]
    pub filter: Option<String>,
    /// Samples a pixel instead of the protocol's budget (2e6 samples an image).
    #[arg(long)]
    pub spp: Option<u32>,
    /// The render's seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
}

pub fn run(args: &MitsubaTestsArgs) -> Result<()> {
    let cases: Vec<_> = mitsuba_tests::cases(&args.data)?
        .into_iter()
        .filter(|c| args.filter.as_ref().is_none_or(|f| c.name.contains(f)))
        .collect();
    if cases.is_empty() {
        bail!("no test scene matches");
    }
    let budget = Budget {
        spp: args.spp,
        seed: args.seed,
    };
    let mut failed = 0;
    for &backend in &args.backend {
        if backend == Backend::Auto {
            bail!("--backend takes cpu or gpu");
        }
        let (gpus, name, _) = choose_device(backend)?;
        let twin = if backend == Backend::Cpu {
            "cpu"
        } else {
            "gpu"
        };
        println!("# {twin}: {name}");
        for case in &cases {
            match mitsuba_tests::run(case, Devices::of(&gpus, None), budget) {
                Ok(Outcome::Refused(line)) => {
                    println!(
                        "{:<52} {twin} REFUSED {}",
                        case.name,
                        super::common::one_line(&line)
                    )
                }
                Ok(Outcome::Judged { verdict, spp }) => {
                    // The verdict is Mitsuba's protocol's: mitsuba-data's
                    // stored references are up to 0.1 % off a channel from
                    // what Mitsuba 3.9.1 renders, which the image sums see
                    // (docs/mitsuba.md, "Results"); they are shown, marked.
                    let word = if verdict.mitsuba_passes() {
                        "PASS"
                    } else {
                        "FAIL"
                    };
                    if !verdict.mitsuba_passes() {
                        failed += 1;
                    }
                    let sums = if verdict.sums_pass() {
                        ""
                    } else {
                        " [image sums outside their bound]"
                    };
                    println!(
                        "{:<52} {twin} {word} {spp} spp: {}{sums}",
                        case.name,
                        verdict.figures()
                    );
                }
                Err(e) => {
                    failed += 1;
                    println!(
                        "{:<52} {twin} ERROR {}",
                        case.name,
                        super::common::one_line(&format!("{e:#}"))
                    );
                }
            }
        }
    }
    if failed > 0 {
        bail!("mitsuba-tests: {failed} failed (see their lines)");
    }
    Ok(())
}
