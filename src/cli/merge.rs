//! `twintrace merge`: partial films of one render into the film of their
//! sample range.

use super::common::print_stdout;
use super::outputs;
use super::render::render_outputs;
use anyhow::Result;
use clap::Args;
use std::path::PathBuf;
use twintrace::image_io::{self, AtomicFile};
use twintrace::tonemap::Tonemap;

#[derive(Debug, Args)]
pub struct MergeArgs {
    /// Partial films (EXR) of one render whose sample ranges tile one
    /// range, in any order.
    #[arg(required = true, value_name = "PART")]
    pub parts: Vec<PathBuf>,
    /// Output path; `.exr` and `.png` are added (a given .exr/.png extension is dropped).
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    pub output: PathBuf,
    /// Display transform for the PNG (the EXR is always linear).
    #[arg(long, value_enum, default_value_t = Tonemap::Aces)]
    pub tonemap: Tonemap,
}

/// `twintrace merge`: reads every part (each checked whole), merges them
/// ([`twintrace::partial::merge`]) and writes the film of their range.
pub(super) fn merge(args: &MergeArgs) -> Result<()> {
    // Fail on an unusable output path before reading the parts, and on
    // an output that would overwrite one of them.
    let paths = image_io::output_paths(&args.output)?;
    let parts: Vec<outputs::Named> = args
        .parts
        .iter()
        .map(|p| outputs::input_file("part", p))
        .collect();
    outputs::check(&parts, &render_outputs("-o", &args.output, &paths))?;
    drop(AtomicFile::create(&paths.exr)?);
    let mut parts = Vec::with_capacity(args.parts.len());
    for path in &args.parts {
        parts.push((path.clone(), twintrace::partial::Part::read(path)?));
    }
    let count = parts.len();
    let merged = twintrace::partial::merge(parts)?;
    merged.write(&args.output, args.tonemap)?;
    print_stdout(&format!(
        "merged {count} parts: samples {}..{} of {} ({}) -> {}, {}\n",
        merged.samples.start,
        merged.samples.end,
        merged.metadata.scene.as_deref().unwrap_or("a scene"),
        merged.devices,
        paths.exr.display(),
        paths.png.display()
    ))
}
