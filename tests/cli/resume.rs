//! Resumable renders (docs/split-renders.md, "Interrupted renders"): a
//! render stopped by SIGINT or SIGTERM at seeded random points (before
//! its first chunk, in the middle, near the end) writes the samples done
//! as a partial film and one line with the command that continues it;
//! that command, itself interrupted once, ends with the EXR an
//! uninterrupted render writes, bit for bit. A checkpoint survives
//! SIGKILL; a second SIGINT exits at once and leaves the files whole. `--resume` refuses, in one line with exit status 2, a part of
//! another render (each field of its key, and its sample range) and an
//! output that would overwrite the part; the comparison catches a forged
//! part. The chunked render holds the whole render's film, a chunk
//! that fails leaves the chunks before it to be saved, and the CPU
//! reference drops a chunk in flight when stopped between its tiles.
//!
//! The GPU's runs are in tests/gpu/gpu_resume.rs, through the helpers here.

use reference::film::FilmSums;
use reference::RenderSettings;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};
use twintrace::partial::Part;
use twintrace::render::{
    add_chunked, held_film, Added, Chunking, CpuProgressive, Hooks, Job, JobOptions, Layers,
    Phases, Progressive, RenderSpec,
};

/// A finished `twintrace` process.
pub(crate) struct Outcome {
    pub status: ExitStatus,
    pub stdout: String,
    pub stderr: String,
}

impl Outcome {
    /// The exit status, or 128 + the signal that ended the process.
    pub fn code(&self) -> i32 {
        use std::os::unix::process::ExitStatusExt;
        match (self.status.code(), self.status.signal()) {
            (Some(c), _) => c,
            (None, Some(s)) => 1000 + s,
            (None, None) => -1,
        }
    }
}

fn finish(child: std::process::Child) -> Outcome {
    let out = child.wait_with_output().expect("the binary runs");
    Outcome {
        status: out.status,
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// Starts `program args` in `dir`.
fn start(dir: &Path, program: &Path, args: &[String]) -> std::process::Child {
    Command::new(program)
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the binary starts")
}

/// Runs `twintrace args` in `dir`, sending `signal` after `delay` where
/// one is given (the process may have ended by then).
pub(crate) fn twintrace(dir: &Path, args: &[String], signal: Option<(Duration, i32)>) -> Outcome {
    run_program(dir, &common_bin(), args, signal)
}

fn common_bin() -> PathBuf {
    crate::common::twintrace_bin()
}

fn run_program(
    dir: &Path,
    program: &Path,
    args: &[String],
    signal: Option<(Duration, i32)>,
) -> Outcome {
    let mut child = start(dir, program, args);
    if let Some((delay, signal)) = signal {
        let until = Instant::now() + delay;
        while Instant::now() < until {
            if child.try_wait().expect("wait").is_some() {
                return finish(child);
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        // SAFETY: kill(2) on the child's pid, which has not been reaped
        // (try_wait saw it running), so the pid is still the child's.
        unsafe {
            libc::kill(child.id() as libc::pid_t, signal);
        }
    }
    finish(child)
}

fn strings(args: &[&str]) -> Vec<String> {
    args.iter().map(|s| s.to_string()).collect()
}

/// The film layers of a render EXR as bits (NaN compares too), with its
/// size; `Err` names what differs first.
pub(crate) fn same_film(got: &Path, want: &Path) -> Result<(), String> {
    let read = |p: &Path| twintrace::read_exr(p).map_err(|e| format!("{}: {e:#}", p.display()));
    let (a, b) = (read(got)?, read(want)?);
    if (a.width, a.height) != (b.width, b.height) {
        return Err(format!(
            "size {}x{}, not {}x{}",
            a.width, a.height, b.width, b.height
        ));
    }
    if a.metadata.spp != b.metadata.spp {
        return Err(format!(
            "spp {:?}, not {:?}",
            a.metadata.spp, b.metadata.spp
        ));
    }
    fn layers(i: &twintrace::image_io::RenderImage) -> [Option<&Vec<glam::Vec3>>; 3] {
        [Some(&i.mean), i.variance.as_ref(), i.skewness.as_ref()]
    }
    for (name, (x, y)) in ["mean", "variance", "skewness"]
        .iter()
        .zip(layers(&a).into_iter().zip(layers(&b)))
    {
        let (Some(x), Some(y)) = (x, y) else {
            return Err(format!("the {name} layer is missing"));
        };
        for (p, (u, v)) in x.iter().zip(y).enumerate() {
            let (u, v) = (
                u.to_array().map(f32::to_bits),
                v.to_array().map(f32::to_bits),
            );
            if u != v {
                return Err(format!(
                    "{name} of pixel {p} is {:?}, not {:?}",
                    u.map(f32::from_bits),
                    v.map(f32::from_bits)
                ));
            }
        }
    }
    // The files whole, too: attributes and channels are written sorted,
    // so identical renders are identical bytes.
    if std::fs::read(got).unwrap() != std::fs::read(want).unwrap() {
        return Err("the layers are equal but the files' bytes differ".into());
    }
    Ok(())
}

/// SplitMix64: the interrupt points, from a seed.
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        (z ^ (z >> 31)) as f64 / u64::MAX as f64
    }
}

fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// The command after "continue with: " in an interruption's line.
fn continue_command(line: &str) -> &str {
    let (_, cmd) = line
        .split_once("continue with: ")
        .unwrap_or_else(|| panic!("no command to continue in {line:?}"));
    cmd
}

/// Renders `render` (a `twintrace render …` command without `-o`) whole,
/// then again interrupted at seeded random points: at once, halfway
/// through its start-up (scene, device, kernels: before the first chunk),
/// at `middle` random points of its tracing, and near its end (the
/// phases' times from the whole render's `--json`), alternately by SIGINT
/// and SIGTERM. Each interrupted run's own continue command is run (the
/// first middle one's interrupted again a quarter into what it has left,
/// and continued again),
/// and the EXR it ends with must be the whole render's, bit for bit.
/// At least one run must be resumed from a part; what each point did is
/// printed.
pub(crate) fn interrupt_and_resume(render: &[String], seed: u64, middle: usize) {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let with_output = |out: &str| {
        let mut a = render.to_vec();
        a.extend(strings(&["-o", out]));
        a
    };
    let mut args = with_output("whole");
    let json_summary = render.iter().any(|a| a == "--json");
    if !json_summary {
        args.push("--json".into());
    }
    if render.iter().any(|a| a == "gpu") {
        // The first GPU run fills the pipeline cache; the runs timed are
        // the ones after it.
        let o = twintrace(dir, &args, None);
        assert_eq!(o.code(), 0, "the whole render: {}", o.stderr);
    }
    let whole = twintrace(dir, &args, None);
    assert_eq!(whole.code(), 0, "the whole render: {}", whole.stderr);
    let json: serde_json::Value = serde_json::from_str(&whole.stdout).unwrap();
    let phase = |name: &str| json["phases_s"][name].as_f64().unwrap();
    let startup = phase("scene") + phase("device") + phase("kernels and upload");
    let tracing = phase("rendering");
    let mut rng = Rng(seed);
    let mut points = vec![0.0, 0.5 * startup];
    points.extend((0..middle).map(|_| startup + tracing * (0.1 + 0.8 * rng.unit())));
    points.push(startup + 0.95 * tracing);
    let mut resumed = 0;
    let mut retries = 0;
    let mut log = String::new();
    for (k, at) in points.iter().enumerate() {
        let at = Duration::from_secs_f64(*at);
        let out = format!("r{k}");
        let (signal, code) = if k % 2 == 0 {
            (libc::SIGINT, 130)
        } else {
            (libc::SIGTERM, 143)
        };
        let what = format!(
            "{render:?} interrupted at {at:?} (start-up {startup:.3} s, tracing {tracing:.3} s)"
        );
        // A middle point that missed the tracing (this run's start-up or
        // speed was not the whole render's: the machine is shared) moves
        // by bisection between the points known to be too early and too
        // late, six times at most in all.
        let (mut at, mut early, mut late) = (at, Duration::ZERO, None::<Duration>);
        let o = loop {
            let o = twintrace(dir, &with_output(&out), Some((at, signal)));
            log += &format!("\n{at:?}: exit {}, {}", o.code(), o.stderr.trim());
            let missed = if o.code() == 0 {
                late = Some(at);
                let done = dir.join(format!("{out}.exr"));
                same_film(&done, &dir.join("whole.exr")).unwrap_or_else(|e| panic!("{what}: {e}"));
                std::fs::remove_file(done).unwrap();
                std::fs::remove_file(dir.join(format!("{out}.png"))).unwrap();
                true
            } else if o.stderr.contains("nothing was written") {
                early = at;
                true
            } else {
                false
            };
            if missed && (2..2 + middle).contains(&k) && retries < 6 {
                retries += 1;
                at = match late {
                    Some(late) => (early + late) / 2,
                    None => at.mul_f64(1.5),
                };
                continue;
            }
            break o;
        };
        let exr = dir.join(format!("{out}.exr"));
        let part = dir.join(format!("{out}.partial.exr"));
        match o.code() {
            // Done before the signal came (its film checked above).
            0 => continue,
            // Before the handler was installed (the process's first
            // milliseconds): the default action, nothing written.
            c if c == 1000 + signal && k < 2 => {
                assert!(!files(dir).iter().any(|f| f.starts_with(&out)), "{what}");
                continue;
            }
            c => assert_eq!(c, code, "{what}: stderr {}", o.stderr),
        }
        let lines: Vec<&str> = o.stderr.lines().collect();
        assert_eq!(lines.len(), 1, "{what}: {:?}", o.stderr);
        let name = if signal == libc::SIGINT {
            "SIGINT"
        } else {
            "SIGTERM"
        };
        assert!(
            lines[0].starts_with(&format!("interrupted by {name}")),
            "{what}: {}",
            lines[0]
        );
        assert!(!exr.exists(), "{what}: the output was written");
        // Nothing half-written: no temporary file left.
        assert!(
            !files(dir).iter().any(|f| f.ends_with(".tmp")),
            "{what}: {:?}",
            files(dir)
        );
        if lines[0].contains("nothing was written") {
            assert!(!part.exists(), "{what}");
            continue;
        }
        assert!(part.exists(), "{what}: {}", lines[0]);
        let held = Part::read(&part).unwrap();
        if json_summary {
            // The summary object says the same.
            let j: serde_json::Value = serde_json::from_str(&o.stdout).unwrap();
            assert_eq!(j["interrupted"], name, "{}", o.stdout);
            assert_eq!(j["partial"], format!("{out}.partial.exr"), "{}", o.stdout);
            assert_eq!(j["samples"][1], held.samples.end, "{}", o.stdout);
            assert_eq!(
                j["resume_command"].as_str(),
                Some(continue_command(lines[0])),
                "{}",
                o.stdout
            );
        }
        assert!(lines[0].contains(&format!(
            "samples {}..{}",
            held.samples.start, held.samples.end
        )));
        // The line's own command, through a shell as a user pastes it
        // (`exec`: the signal reaches twintrace, not the shell).
        let sh = |cmd: &str, signal: Option<(Duration, i32)>| {
            run_program(
                dir,
                Path::new("/bin/sh"),
                &strings(&["-c", &format!("exec {cmd}")]),
                signal,
            )
        };
        let mut cmd = continue_command(lines[0]).to_string();
        if k == 2 {
            // Interrupted again, a quarter into what is left.
            let left = (startup + tracing - at.as_secs_f64()).max(0.0);
            let again = sh(
                &cmd,
                Some((Duration::from_secs_f64(startup + 0.25 * left), libc::SIGINT)),
            );
            log += &format!(
                ", resumed and interrupted: exit {}, {}",
                again.code(),
                again.stderr.trim()
            );
            if again.code() == 130 {
                if let Some(line) = again.stderr.lines().find(|l| l.contains("continue with: ")) {
                    cmd = continue_command(line).to_string();
                }
            }
        }
        if !exr.exists() {
            let r = sh(&cmd, None);
            assert_eq!(r.code(), 0, "{what}: resuming `{cmd}`: {}", r.stderr);
            let said = if json_summary {
                let j: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
                j["resumed"]["samples"][0] == 0
            } else {
                r.stdout.contains("(resumed: samples")
            };
            assert!(said, "{what}: {}", r.stdout);
        }
        same_film(&exr, &dir.join("whole.exr")).unwrap_or_else(|e| panic!("{what}, resumed: {e}"));
        resumed += 1;
    }
    eprintln!("{log}");
    assert!(resumed >= 1, "no run was resumed: {log}");
}

/// `twintrace render cornell --backend BACKEND --size SIZE --spp SPP`,
/// then `extra`.
pub(crate) fn cornell(backend: &str, size: &str, spp: &str, extra: &[&str]) -> Vec<String> {
    let mut args = strings(&[
        "render",
        "cornell",
        "--backend",
        backend,
        "--size",
        size,
        "--spp",
        spp,
    ]);
    args.extend(strings(extra));
    args
}

/// Seeded interrupt points on the CPU reference: 2048 samples a pixel of
/// a 16x16 Cornell box, about 1 s on the debug build, in chunks from
/// one sample up to [`twintrace::render::CHUNK_TIME`].
#[test]
fn interrupted_cpu_renders_resume_to_the_whole_render_bit_for_bit() {
    let render = cornell("cpu", "16x16", "2048", &["--seed", "3"]);
    interrupt_and_resume(&render, 0x5eed_0043, 2);
}

/// A budgeted render (`--time` with an `--spp` cap) interrupted and
/// resumed reaches its cap: the whole film again, bit for bit; with
/// `--json`, the interrupted run's summary names the signal, the part and
/// the command.
#[test]
fn an_interrupted_budgeted_render_resumes_to_its_cap() {
    let render = cornell("cpu", "16x16", "2048", &["--time", "1h", "--json"]);
    interrupt_and_resume(&render, 0x5eed_0044, 1);
}

/// SIGKILL cannot be answered: `--checkpoint` has written the samples
/// done, atomically, and the render continues from them.
#[test]
fn a_killed_render_resumes_from_its_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let with = |extra: &[&str]| cornell("cpu", "16x16", "2048", extra);
    let whole = twintrace(dir, &with(&["-o", "whole"]), None);
    assert_eq!(whole.code(), 0, "{}", whole.stderr);
    let part = dir.join("k.partial.exr");
    // Killed once the first checkpoint is there (a checkpoint every 0.1 s).
    let mut child = start(
        dir,
        &common_bin(),
        &with(&["-o", "k", "--checkpoint", "100ms"]),
    );
    let until = Instant::now() + Duration::from_secs(60);
    while !part.exists() && Instant::now() < until && child.try_wait().unwrap().is_none() {
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    let killed = finish(child);
    assert_ne!(killed.code(), 0, "the render ended before it was killed");
    let held = Part::read(&part).expect("the checkpoint is whole");
    assert!(held.samples.start == 0 && held.samples.end < 2048);
    let o = twintrace(dir, &with(&["-o", "k", "--resume", "k.partial.exr"]), None);
    assert_eq!(o.code(), 0, "{}", o.stderr);
    same_film(&dir.join("k.exr"), &dir.join("whole.exr")).unwrap();
}

/// A part of the render `args` (a 2-sample part of 4) in `dir` as `p.exr`.
fn small_part(dir: &Path) -> PathBuf {
    let o = twintrace(
        dir,
        &cornell("cpu", "8x6", "4", &["--samples", "0..2", "-o", "p"]),
        None,
    );
    assert_eq!(o.code(), 0, "{}", o.stderr);
    dir.join("p.exr")
}

/// Each field of the key, the range and an output naming the part: one
/// line naming what differs, exit status 2, nothing written, the part
/// untouched.
#[test]
fn resume_refuses_a_part_of_another_render_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    // Samples 0..2 of a 4-sample render, as an interrupted render leaves
    // them (its target range named).
    let mut interrupted = Part::read(&small_part(dir)).unwrap();
    interrupted.target = Some(0..4);
    interrupted
        .write(&dir.join("p"), twintrace::tonemap::Tonemap::Aces)
        .unwrap();
    let part = dir.join("p.exr");
    // A part of another version: the key's version rewritten.
    let mut other = Part::read(&part).unwrap();
    other.key.version = "0.0.1".into();
    other
        .write(&dir.join("v"), twintrace::tonemap::Tonemap::Aces)
        .unwrap();
    let bytes = std::fs::read(&part).unwrap();
    // The command of the part, with one option changed (clap refuses an
    // option given twice).
    let command = |scene: &str, change: &[&str], resume: &str| {
        let mut options = vec![
            ("--backend", "cpu"),
            ("--size", "8x6"),
            ("--spp", "4"),
            ("-o", "out"),
        ];
        for pair in change.chunks(2) {
            match options.iter_mut().find(|(k, _)| *k == pair[0]) {
                Some(o) => o.1 = pair[1],
                None => options.push((pair[0], pair[1])),
            }
        }
        let mut args = strings(&["render", scene, "--resume", resume]);
        for (k, v) in options {
            args.extend(strings(&[k, v]));
        }
        args
    };
    let cases: [(&[&str], &str, &str); 10] = [
        (
            &["--size", "8x8"],
            "p.exr",
            "its size is 8x6, this command's is 8x8 (--size)",
        ),
        (
            &["--seed", "5"],
            "p.exr",
            "its seed is 0, this command's is 5 (--seed)",
        ),
        (
            &["--max-depth", "3"],
            "p.exr",
            "its maxDepth is 50, this command's is 3",
        ),
        (
            &["--integrator", "bsdf"],
            "p.exr",
            "its integrator is mis, this command's is bsdf",
        ),
        (
            &["--sampler", "independent"],
            "p.exr",
            "its sampler is sobol, this command's is independent (--sampler",
        ),
        (
            &["--spp", "8"],
            "p.exr",
            "render of samples 0..4 (spp 4), this command renders 0..8 (spp 8",
        ),
        (
            &["--samples", "1..4"],
            "p.exr",
            "holds samples 0..2, this command renders 1..4",
        ),
        (&[], "v.exr", "rendered by twintrace 0.0.1"),
        (
            &["-o", "p"],
            "p.exr",
            "-o p (`p.exr`) would overwrite the resume part `p.exr`",
        ),
        (&[], "missing.exr", "missing.exr"),
    ];
    for (change, resume, want) in cases {
        let args = command("cornell", change, resume);
        let before = files(dir);
        let o = twintrace(dir, &args, None);
        assert_eq!(o.code(), 2, "{change:?}: {}", o.stderr);
        let lines: Vec<&str> = o.stderr.lines().collect();
        assert_eq!(lines.len(), 1, "{change:?}: {:?}", o.stderr);
        assert!(
            lines[0].starts_with("error: ") && lines[0].contains(want),
            "{change:?}: {} lacks {want:?}",
            lines[0]
        );
        assert_eq!(files(dir), before, "{change:?} wrote files");
    }
    // Another scene (a scene file of its own).
    std::fs::copy(
        twintrace::compare::gate::workspace_root().join("fixtures/scenes/cornell-spheres.json"),
        dir.join("s.json"),
    )
    .unwrap();
    let o = twintrace(dir, &command("s.json", &[], "p.exr"), None);
    assert_eq!(o.code(), 2, "{}", o.stderr);
    assert!(
        o.stderr.contains("its scene's fingerprint is"),
        "{}",
        o.stderr
    );
    assert_eq!(std::fs::read(&part).unwrap(), bytes, "the part changed");
}

/// The bit-for-bit comparison catches a resume that is wrong: a part whose
/// key says samples 0..2 of this render but whose sums are samples 1..3
/// (resumed, sample 2 counts twice and 0 never), and one of another seed
/// under this render's key. Both are accepted by `--resume` (their keys
/// are forged), and both end with a film [`same_film`] tells apart.
#[test]
fn the_comparison_catches_a_forged_part() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let render = |extra: &[&str]| {
        let o = twintrace(dir, &cornell("cpu", "8x6", "4", extra), None);
        assert_eq!(o.code(), 0, "{extra:?}: {}", o.stderr);
    };
    render(&["-o", "whole"]);
    let honest = Part::read(&small_part(dir)).unwrap();
    render(&["--samples", "1..3", "-o", "shifted"]);
    render(&["--samples", "0..2", "--seed", "1", "-o", "seeded"]);
    for forged in ["shifted", "seeded"] {
        let mut part = Part::read(&dir.join(format!("{forged}.exr"))).unwrap();
        part.key = honest.key.clone();
        part.samples = 0..2;
        part.target = Some(0..4);
        part.metadata = honest.metadata.clone();
        part.write(
            &dir.join(format!("{forged}-part")),
            twintrace::tonemap::Tonemap::Aces,
        )
        .unwrap();
        render(&["-o", forged, "--resume", &format!("{forged}-part.exr")]);
        let verdict = same_film(&dir.join(format!("{forged}.exr")), &dir.join("whole.exr"));
        assert!(verdict.is_err(), "{forged}: a forged part passed");
    }
    // The honest part resumes to the whole render.
    render(&["-o", "honest", "--resume", "p.exr"]);
    same_film(&dir.join("honest.exr"), &dir.join("whole.exr")).unwrap();
}

fn tiny() -> RenderSettings {
    RenderSettings {
        width: 6,
        height: 5,
        spp: 64,
        max_depth: 5,
        seed: 4,
        ..RenderSettings::default()
    }
}

/// A CPU render whose `fail_at`-th add fails, as a device lost mid-render.
struct Failing<'a> {
    inner: CpuProgressive<'a>,
    adds: usize,
    fail_at: usize,
}

impl Progressive for Failing<'_> {
    fn device(&self) -> String {
        self.inner.device()
    }
    fn settings(&self) -> &RenderSettings {
        self.inner.settings()
    }
    fn add(
        &mut self,
        samples: Range<u32>,
        progress: &(dyn Fn(u64) + Sync),
    ) -> anyhow::Result<Added> {
        self.adds += 1;
        if self.adds == self.fail_at {
            anyhow::bail!("the device was lost (a test's)");
        }
        self.inner.add(samples, progress)
    }
    fn sums(&mut self) -> anyhow::Result<FilmSums> {
        self.inner.sums()
    }
    fn aovs(&mut self, samples: Range<u32>) -> anyhow::Result<reference::aov::AovSums> {
        self.inner.aovs(samples)
    }
    fn reset(&mut self, settings: RenderSettings) -> anyhow::Result<()> {
        self.inner.reset(settings)
    }
    fn ranges(&self) -> &[Range<u32>] {
        self.inner.ranges()
    }
}

fn layer_bits(sums: &FilmSums) -> Vec<u32> {
    let l = Layers::from_sums(sums);
    l.mean
        .iter()
        .chain(&l.variance)
        .chain(&l.skewness)
        .flat_map(|v| v.to_array().map(f32::to_bits))
        .collect()
}

/// Chunks of one sample (a chunk time of zero) add up to the whole range's
/// film bit for bit; a stop after three chunks leaves three; a failing
/// chunk leaves the chunks before it, which [`held_film`] reads whole, and
/// equal to a render of just those samples. A film holding two ranges is
/// no prefix: refused.
#[test]
fn chunks_add_up_and_a_failed_chunk_leaves_the_ones_before() {
    let scene = reference::load_scene("cornell").unwrap();
    let spec = RenderSpec::DEFAULT;
    let settings = tiny();
    let whole = {
        let mut p = CpuProgressive::new(&scene, &spec, settings, None).unwrap();
        p.add(5..64, &|_| {}).unwrap();
        p.sums().unwrap()
    };
    let never = || false;
    let mut nothing = |_: &mut dyn Progressive| Ok(());
    let mut c = Chunking::new(Duration::ZERO, &never, &mut nothing);
    let mut p = CpuProgressive::new(&scene, &spec, settings, None).unwrap();
    let added = add_chunked(&mut p, 5..64, Some(&mut c), &|_| {}).unwrap();
    assert_eq!((added.end, added.stopped), (64, false));
    assert_eq!(p.sums().unwrap(), whole);
    assert_eq!(layer_bits(&p.sums().unwrap()), layer_bits(&whole));

    let chunks = AtomicUsize::new(0);
    let stop = || chunks.load(Ordering::SeqCst) == 3;
    let mut count = |_: &mut dyn Progressive| {
        chunks.fetch_add(1, Ordering::SeqCst);
        Ok(())
    };
    let mut c = Chunking::new(Duration::ZERO, &stop, &mut count);
    let mut p = CpuProgressive::new(&scene, &spec, settings, None).unwrap();
    let added = add_chunked(&mut p, 0..64, Some(&mut c), &|_| {}).unwrap();
    assert_eq!((added.end, added.stopped), (3, true));

    let mut f = Failing {
        inner: CpuProgressive::new(&scene, &spec, settings, None).unwrap(),
        adds: 0,
        fail_at: 4,
    };
    let mut c = Chunking::new(Duration::ZERO, &never, &mut nothing);
    let e = add_chunked(&mut f, 0..64, Some(&mut c), &|_| {}).unwrap_err();
    assert!(e.to_string().contains("lost"), "{e}");
    let (end, sums) = held_film(&mut f, 0).unwrap();
    assert_eq!(end, 3);
    let mut fresh = CpuProgressive::new(&scene, &spec, settings, None).unwrap();
    fresh.add(0..3, &|_| {}).unwrap();
    assert_eq!(sums, fresh.sums().unwrap());

    fresh.add(5..6, &|_| {}).unwrap();
    let e = held_film(&mut fresh, 0).unwrap_err().to_string();
    assert!(e.contains("not one range from 0"), "{e}");
}

/// The CPU reference abandons a range in flight between its tiles: a stop
/// that turns true once the first tile is done leaves the film as it was
/// (no range, no sums), and [`add_chunked`] says it stopped where it was.
#[test]
fn the_cpu_reference_abandons_the_chunk_in_flight() {
    let scene = reference::load_scene("cornell").unwrap();
    let spec = RenderSpec::DEFAULT;
    // 64x48: 12 tiles of 16x16 (reference::integrator::TILE_SIZE); one
    // thread, so the tiles after the first see the stop.
    let settings = RenderSettings {
        width: 64,
        height: 48,
        ..tiny()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut p = CpuProgressive::new(&scene, &spec, settings, Some(&pool)).unwrap();
    p.add(0..2, &|_| {}).unwrap();
    let before = p.sums().unwrap();
    let tile_done = AtomicBool::new(false);
    let stop = || tile_done.load(Ordering::SeqCst);
    let progress = |_| tile_done.store(true, Ordering::SeqCst);
    let out = p.add_until(2..40, &progress, &stop).unwrap();
    assert!(out.is_none(), "the range was not abandoned");
    assert_eq!(p.ranges(), std::slice::from_ref(&(0..2)));
    assert_eq!(p.sums().unwrap(), before);

    tile_done.store(false, Ordering::SeqCst);
    let mut nothing = |_: &mut dyn Progressive| Ok(());
    let mut c = Chunking::new(Duration::from_secs(3600), &stop, &mut nothing);
    // The first chunk (one sample) is abandoned too: the stop is seen
    // after its first tile.
    let added = add_chunked(&mut p, 2..40, Some(&mut c), &progress).unwrap();
    assert_eq!((added.end, added.stopped), (2, true));
    assert_eq!(p.sums().unwrap(), before);
    // Never stopped, the same range is whole.
    let never = || false;
    assert!(p.add_until(2..40, &|_| {}, &never).unwrap().is_some());
    assert_eq!(p.ranges(), std::slice::from_ref(&(0..40)));
}

/// The library's render job ([`Job`]), with no process around it. With a
/// checkpoint after every chunk (an interval of zero: chunks of one
/// sample), a job stopped by its hook after a few chunks writes the
/// samples done as its partial film; a job resuming that part writes the
/// image of a job never stopped, bit for bit. A job whose render fails in
/// its third chunk (a device lost) saves the two chunks before it and
/// names the part and how to continue (the hook's words); one that fails in its first saves
/// nothing and says so.
#[test]
fn a_job_stopped_and_resumed_writes_the_whole_render_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let scene = reference::load_scene("cornell").unwrap();
    let spec = RenderSpec::DEFAULT;
    let settings = tiny();
    let every_chunk = JobOptions {
        checkpoint: Some(Duration::ZERO),
        ..JobOptions::default()
    };
    let never = || false;
    let resume_hint = |p: &Path| format!("RESUME {}", p.display());
    let run = |job: &Job, render: &mut dyn Progressive, stop: &(dyn Fn() -> bool + Sync)| {
        let hooks = Hooks {
            stop,
            progress: &|_| {},
            status: &mut |_, _, _| {},
            continue_with: &resume_hint,
        };
        job.render(render, hooks)
    };
    let cpu = || CpuProgressive::new(&scene, &spec, settings, None).unwrap();
    let job = |name: &str, options: JobOptions| {
        Job::new(&scene, "cornell", spec, settings, &dir.join(name), options).unwrap()
    };
    let failing = |fail_at| Failing {
        inner: cpu(),
        adds: 0,
        fail_at,
    };

    let whole = job("whole", JobOptions::default());
    let mut p = cpu();
    let done = run(&whole, &mut p, &never).unwrap();
    assert_eq!((done.end, done.interrupted.clone()), (64, None));
    whole
        .write(&mut p, done.end, &mut Phases::default())
        .unwrap();

    let stopped = job("out", every_chunk.clone());
    let chunks = AtomicUsize::new(0);
    let stop = || chunks.fetch_add(1, Ordering::SeqCst) >= 6;
    let mut p = cpu();
    let done = run(&stopped, &mut p, &stop).unwrap();
    let part = stopped.partial_paths().exr.clone();
    assert_eq!(done.interrupted, Some(Some(part.clone())));
    assert!((1..64).contains(&done.end), "stopped at {}", done.end);
    let read = Part::read(&part).unwrap();
    assert_eq!(read.samples, 0..done.end);

    let mut resumed = job("resumed", JobOptions::default());
    resumed.resume(&part, read).unwrap();
    assert_eq!(resumed.todo(), done.end..64);
    let mut p = cpu();
    let rest = run(&resumed, &mut p, &never).unwrap();
    assert_eq!((rest.end, rest.interrupted), (64, None));
    resumed
        .write(&mut p, rest.end, &mut Phases::default())
        .unwrap();
    same_film(&dir.join("resumed.exr"), &dir.join("whole.exr")).unwrap();

    let lost = job("lost", every_chunk.clone());
    let mut f = failing(3);
    let e = format!("{:#}", run(&lost, &mut f, &never).unwrap_err());
    let saved = lost.partial_paths().exr.clone();
    assert!(e.contains("the device was lost (a test's)"), "{e}");
    let held = Part::read(&saved).unwrap().samples;
    assert!(held.start == 0 && (1..64).contains(&held.end), "{held:?}");
    let said = format!(
        "samples 0..{} of 0..64 are saved in `{}`: continue with: RESUME {}",
        held.end,
        saved.display(),
        saved.display()
    );
    assert!(e.contains(&said), "{e}");

    let first = job("first", every_chunk);
    let mut f = failing(1);
    let e = format!("{:#}", run(&first, &mut f, &never).unwrap_err());
    assert!(e.contains("nothing was saved (no sample was done;"), "{e}");
    assert!(!first.partial_paths().exr.exists());
}

/// A second signal ends the render at once, with 130, while its chunk is
/// in flight: the files written before stay as they were (here the
/// output of an earlier run and a partial film), and nothing new appears
/// but, at most, a hidden temporary file.
#[test]
fn a_second_interrupt_exits_at_once_leaving_the_files_whole() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    // One 16x16 tile: the CPU reference finishes its chunk (up to
    // CHUNK_TIME), in which the second signal comes.
    let render = cornell("cpu", "16x16", "2048", &["-o", "out"]);
    let mut json = render.clone();
    json.push("--json".into());
    let o = twintrace(dir, &json, None);
    assert_eq!(o.code(), 0, "{}", o.stderr);
    let j: serde_json::Value = serde_json::from_str(&o.stdout).unwrap();
    let tracing = Duration::from_secs_f64(j["phases_s"]["rendering"].as_f64().unwrap());
    std::fs::write(dir.join("out.partial.exr"), b"an earlier part").unwrap();
    // The files as a run finds them: a run that ends on one signal (or
    // none) saves its part (or output), and the next run is held to the
    // files it left.
    let hidden_temporary = |f: &String| f.starts_with('.') && f.ends_with(".tmp");
    let snapshot = || -> Vec<(String, Vec<u8>)> {
        files(dir)
            .into_iter()
            .filter(|f| !hidden_temporary(f))
            .map(|f| (f.clone(), std::fs::read(dir.join(&f)).unwrap()))
            .collect()
    };
    let mut twice = 0;
    let mut log = String::new();
    for at in [0.3, 0.5, 0.7] {
        let before = snapshot();
        let mut child = start(dir, &common_bin(), &render);
        std::thread::sleep(tracing.mul_f64(at));
        for _ in 0..2 {
            if child.try_wait().unwrap().is_none() {
                // SAFETY: kill(2) on the running (unreaped) child's pid.
                unsafe {
                    libc::kill(child.id() as libc::pid_t, libc::SIGINT);
                }
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        let o = finish(child);
        log += &format!("\n{at}: exit {}, {}", o.code(), o.stderr.trim());
        if o.code() == 0 {
            // Done before the signals: it wrote its output again.
            continue;
        }
        assert_eq!(o.code(), 130, "{log}");
        if !o.stderr.contains("interrupted again: exiting at once") {
            continue;
        }
        twice += 1;
        let now: Vec<String> = files(dir)
            .into_iter()
            .filter(|f| !hidden_temporary(f))
            .collect();
        assert_eq!(
            now,
            before.iter().map(|(f, _)| f.clone()).collect::<Vec<_>>(),
            "{log}"
        );
        for (f, bytes) in &before {
            assert!(
                &std::fs::read(dir.join(f)).unwrap() == bytes,
                "{f} changed: {log}"
            );
        }
    }
    assert!(
        twice >= 1,
        "no second signal came while the render ran: {log}"
    );
}
