//! `cargo xtask bless [--perf] [--integrator mis|bsdf] [--scene NAME]...
//! [--spp N]`: regenerates stored references. Tests never write them; this
//! command does, explicitly. `--perf` works on the performance suite's
//! error references (`fixtures/refs/perf/`, larger images that `twintrace
//! perf` measures relMSE against) instead of the gates' (`fixtures/refs/`).
//! `--integrator` picks the estimator: `bsdf` (default) writes the
//! BSDF-sampled set, `fixtures/refs/`, that BSDF renders are gated
//! against; `mis` the set of the default estimator, `fixtures/refs/mis/`,
//! for MIS renders (both sets from the same manifest); the perf references
//! are BSDF-sampled.
//!
//! For each line of `fixtures/refs/manifest.txt` (`name scene WIDTHxHEIGHT
//! spp seed max_depth`; all lines, or those named by `--scene`) it runs
//! `twintrace render --backend cpu` (the scalar reference, release build)
//! into `fixtures/refs/NAME.exr` and writes `NAME.provenance.txt`:
//! renderer, source revision, command, spp, seed, date, machine, time.
//! `--spp N` also rewrites the spp column of the selected lines, so the
//! manifest keeps describing the files (the image tests check that).

use crate::util::{refused, run as sh, write_atomic};
use std::path::Path;
use std::process::Command;
use std::time::Instant;

pub(crate) const MANIFEST: &str = "fixtures/refs/manifest.txt";
pub(crate) const REFS: &str = "fixtures/refs";
/// The performance suite's references (same manifest format).
pub(crate) const PERF_MANIFEST: &str = "fixtures/refs/perf/manifest.txt";
const PERF_REFS: &str = "fixtures/refs/perf";
/// The gates' MIS-rendered references (same manifest as [`REFS`]).
pub(crate) const MIS_REFS: &str = "fixtures/refs/mis";

pub(crate) struct Line {
    pub name: String,
    pub scene: String,
    pub size: String,
    spp: String,
    seed: String,
    pub depth: String,
}

pub(crate) fn parse(text: &str, file: &str) -> Result<Vec<(usize, Line)>, String> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() != 6 {
            return Err(format!(
                "{file}:{}: expected `name scene WIDTHxHEIGHT spp seed max_depth`",
                i + 1
            ));
        }
        let [name, scene, size, spp, seed, depth] =
            [f[0], f[1], f[2], f[3], f[4], f[5]].map(String::from);
        out.push((
            i,
            Line {
                name,
                scene,
                size,
                spp,
                seed,
                depth,
            },
        ));
    }
    Ok(out)
}

/// `line` with its whitespace-separated field `index` replaced, the
/// column alignment kept where the new value is no wider.
fn replace_field(line: &str, index: usize, value: &str) -> String {
    // Byte spans of the fields.
    let mut spans = Vec::new();
    let mut start = None;
    for (i, c) in line
        .char_indices()
        .chain(std::iter::once((line.len(), ' ')))
    {
        match (c.is_whitespace(), start) {
            (false, None) => start = Some(i),
            (true, Some(s)) => {
                spans.push((s, i));
                start = None;
            }
            _ => {}
        }
    }
    let Some(&(s, e)) = spans.get(index) else {
        return line.to_string();
    };
    match spans.get(index + 1) {
        Some(&(next, _)) => format!(
            "{}{value:<width$}{}",
            &line[..s],
            &line[next..],
            width = (next - s).max(value.len() + 1)
        ),
        None => format!("{}{value}{}", &line[..s], &line[e..]),
    }
}

/// Output of a command, or a note that it could not run.
pub(crate) fn capture(program: &str, args: &[&str]) -> String {
    match Command::new(program).args(args).output() {
        Ok(o) if o.status.success() => String::from_utf8_lossy(&o.stdout).trim().to_string(),
        _ => format!("unknown ({program} failed)"),
    }
}

pub(crate) fn machine() -> String {
    let host = std::fs::read_to_string("/etc/hostname")
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|_| capture("hostname", &[]));
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let threads = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!(
        "{host}: {cpu}, {threads} hardware threads, {}-{}",
        std::env::consts::OS,
        std::env::consts::ARCH
    )
}

fn usage() -> String {
    "usage: cargo xtask bless [--perf] [--integrator mis|bsdf] [--scene NAME]... [--spp N]".into()
}

pub fn run(args: &[String]) -> Result<(), String> {
    let mut scenes: Vec<String> = Vec::new();
    let mut spp: Option<u32> = None;
    let mut perf = false;
    let mut integrator: Option<String> = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--perf" => perf = true,
            "--integrator" => {
                integrator = Some(
                    it.next()
                        .filter(|s| *s == "mis" || *s == "bsdf")
                        .ok_or_else(|| format!("--integrator needs mis or bsdf; {}", usage()))?
                        .clone(),
                )
            }
            "--scene" => scenes.push(it.next().ok_or_else(usage)?.clone()),
            "--spp" => {
                spp = Some(
                    it.next()
                        .and_then(|s| s.parse().ok())
                        .filter(|&n| n > 0)
                        .ok_or_else(|| format!("--spp needs a positive number; {}", usage()))?,
                )
            }
            other => return Err(format!("unknown argument `{other}`; {}", usage())),
        }
    }
    let integrator = integrator.unwrap_or_else(|| "bsdf".into());
    let (manifest, refs) = match (perf, integrator.as_str()) {
        (true, "bsdf") => (PERF_MANIFEST, PERF_REFS),
        (true, _) => {
            return Err(
                "the perf references are BSDF-sampled: --perf takes no --integrator mis".into(),
            )
        }
        (false, "bsdf") => (MANIFEST, REFS),
        (false, _) => (MANIFEST, MIS_REFS),
    };
    std::fs::create_dir_all(refs).map_err(|e| format!("cannot create {refs}: {e}"))?;
    let text =
        std::fs::read_to_string(manifest).map_err(|e| format!("cannot read {manifest}: {e}"))?;
    let mut lines = parse(&text, manifest)?;
    if let Some(missing) = scenes
        .iter()
        .find(|s| !lines.iter().any(|(_, l)| &l.name == *s))
    {
        let names: Vec<&str> = lines.iter().map(|(_, l)| l.name.as_str()).collect();
        return Err(format!(
            "no reference `{missing}` in {manifest}; known: {}",
            names.join(", ")
        ));
    }
    lines.retain(|(_, l)| scenes.is_empty() || scenes.contains(&l.name));
    // Two lines of one name would write one reference twice.
    for (k, (i, l)) in lines.iter().enumerate() {
        if let Some((j, _)) = lines[..k].iter().find(|(_, m)| m.name == l.name) {
            return Err(refused(format!(
                "{manifest}:{} and {manifest}:{}: both name the reference `{}` ({refs}/{}.exr); name them apart",
                j + 1,
                i + 1,
                l.name,
                l.name
            )));
        }
    }
    if let Some(n) = spp {
        // Rewrite the spp column of the selected lines, keeping the rest of the file.
        let mut rows: Vec<String> = text.lines().map(String::from).collect();
        for (i, l) in &mut lines {
            l.spp = n.to_string();
            rows[*i] = replace_field(&rows[*i], 3, &l.spp);
        }
        write_atomic(Path::new(manifest), (rows.join("\n") + "\n").as_bytes())?;
    }
    sh(
        "cargo",
        &["build", "--release", "--quiet", "--bin", "twintrace"],
    )?;
    let revision = capture("git", &["rev-parse", "--short", "HEAD"]);
    let dirty = if capture("git", &["status", "--porcelain", "--untracked-files=no"]).is_empty() {
        ""
    } else {
        " with uncommitted changes"
    };
    let machine = machine();
    for (_, l) in &lines {
        let out = format!("{refs}/{}", l.name);
        let render_args = [
            "render",
            &l.scene,
            "-o",
            &out,
            "--backend",
            "cpu",
            "--size",
            &l.size,
            "--spp",
            &l.spp,
            "--seed",
            &l.seed,
            "--max-depth",
            &l.depth,
            "--integrator",
            &integrator,
            // Independent samples: the gates take a reference's per-pixel
            // spread as its noise (twintrace::compare::gate::GATE_SAMPLER).
            "--sampler",
            "independent",
        ];
        let start = Instant::now();
        let mut cargo_args = vec!["run", "--release", "--quiet", "--bin", "twintrace", "--"];
        cargo_args.extend(render_args);
        sh("cargo", &cargo_args)?;
        let seconds = start.elapsed().as_secs_f64();
        // The render command also writes a PNG preview; references keep only the EXR.
        let png = format!("{out}.png");
        if Path::new(&png).exists() {
            std::fs::remove_file(&png).map_err(|e| format!("cannot remove {png}: {e}"))?;
        }
        let note = format!(
            "reference: {name}\nscene: {scene}\nrenderer: twintrace {version} scalar CPU reference (--backend cpu, --integrator {integrator}), release build\nsource: git {revision}{dirty}\n\
             command: twintrace {command}\nsize: {size}, spp {spp}, seed {seed}, max depth {depth}\ndate: {date}\nmachine: {machine}\nrender time: {seconds:.1} s\n",
            name = l.name,
            scene = l.scene,
            version = env!("CARGO_PKG_VERSION"),
            command = render_args.join(" "),
            size = l.size,
            spp = l.spp,
            seed = l.seed,
            depth = l.depth,
            date = capture("date", &["-u", "+%Y-%m-%dT%H:%M:%SZ"]),
        );
        let path = format!("{refs}/{}.provenance.txt", l.name);
        write_atomic(Path::new(&path), note.as_bytes())?;
        eprintln!("xtask: blessed {out}.exr in {seconds:.1} s");
    }
    eprintln!(
        "xtask: {} reference(s) written; gate them with `cargo test --test integration reference_images`",
        lines.len()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::replace_field;

    #[test]
    fn replacing_a_field_keeps_the_columns() {
        let line = "cornell   scenes/c.json  64x64  16384  1     50";
        assert_eq!(
            replace_field(line, 3, "4096"),
            "cornell   scenes/c.json  64x64  4096   1     50"
        );
        assert_eq!(
            replace_field(line, 5, "12"),
            "cornell   scenes/c.json  64x64  16384  1     12"
        );
        assert_eq!(
            replace_field("a b 4x4 8 1 2", 3, "123456"),
            "a b 4x4 123456 1 2"
        );
    }
}
