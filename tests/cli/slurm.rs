//! The Slurm recipe (docs/recipes/slurm/, docs/split-renders.md) on a real
//! Slurm: a single-node cluster (munged, slurmctld and slurmd from
//! Debian's packages, which `cargo xtask test` installs) started here in
//! a temporary folder, on free ports, and stopped after. The recipe's
//! files run unchanged: the array of parts is submitted with `sbatch`,
//! the merge after it with `--dependency=afterok`; one task fails (the
//! binary it runs fails once, as a node might), the merge waits, the
//! failed task is resubmitted alone and the merge pointed at it, and the
//! merged image is a whole render's bit for bit.
//!
//! Slurm's daemons run as root here, as in CI; the test fails (it never
//! skips) on a machine where they cannot be installed or started.

use super::split_render::{layer_bits, tiny_scene, twintrace};
use crate::common;
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};
use twintrace::read_exr;

/// How long the cluster may take to come up, or a job to end. The node
/// comes up in about 2 s and a job of this test's tiny renders is
/// allocated and done in about 3 s (the 2-core development machine,
/// 2026-12-07); a minute leaves room for a loaded CI machine.
const DEADLINE: Duration = Duration::from_secs(60);

/// `name` on the `PATH` or in the system's program folders (a user's
/// `PATH` may leave out `/usr/sbin`, where the daemons are).
fn program(name: &str) -> PathBuf {
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path)
        .chain(["/usr/sbin", "/usr/bin", "/sbin", "/bin"].map(Into::into))
        .map(|d| d.join(name))
        .find(|p| p.is_file())
        .unwrap_or_else(|| {
            panic!(
                "{name} not found: the Slurm test needs Debian's slurmctld, slurmd, \
                 slurm-client and munge (`cargo xtask test` installs them)"
            )
        })
}

/// Two ports nobody listens on now (both held while the second is
/// found, so they differ).
fn free_ports() -> (u16, u16) {
    let a = TcpListener::bind("127.0.0.1:0").unwrap();
    let b = TcpListener::bind("127.0.0.1:0").unwrap();
    (
        a.local_addr().unwrap().port(),
        b.local_addr().unwrap().port(),
    )
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A single-node Slurm cluster in a folder of its own; its daemons are
/// stopped when it is dropped.
struct Cluster {
    dir: tempfile::TempDir,
    daemons: Vec<Child>,
}

impl Cluster {
    fn start() -> Cluster {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        for sub in ["state", "spool"] {
            std::fs::create_dir(d.join(sub)).unwrap();
        }
        let mut cluster = Cluster {
            dir,
            daemons: Vec::new(),
        };
        let d = cluster.dir.path().to_path_buf();
        // munge: a key of its own and its socket in the folder.
        let key = d.join("munge.key");
        let mut bytes = [0u8; 1024];
        std::io::Read::read_exact(
            &mut std::fs::File::open("/dev/urandom").unwrap(),
            &mut bytes,
        )
        .unwrap();
        std::fs::write(&key, bytes).unwrap();
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o400)).unwrap();
        let socket = d.join("munge.socket");
        let munged = Command::new(program("munged"))
            .arg("--foreground")
            .arg("--force")
            .arg(format!("--key-file={}", key.display()))
            .arg(format!("--socket={}", socket.display()))
            .arg(format!("--pid-file={}", d.join("munged.pid").display()))
            .arg(format!("--log-file={}", d.join("munged.log").display()))
            .arg(format!("--seed-file={}", d.join("munged.seed").display()))
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("munged starts");
        cluster.daemons.push(munged);
        cluster.wait_for("munged's socket", || socket.exists());

        // The node as slurmd finds it (its CPUs, boards, sockets, memory):
        // the cluster fits the machine it runs on.
        let probe = Command::new(program("slurmd")).arg("-C").output().unwrap();
        assert!(probe.status.success(), "slurmd -C: {}", text(&probe));
        let node = String::from_utf8_lossy(&probe.stdout)
            .lines()
            .next()
            .unwrap()
            .to_string();
        let name = node
            .split_whitespace()
            .find_map(|f| f.strip_prefix("NodeName="))
            .expect("slurmd -C names the node")
            .to_string();
        let user = String::from_utf8_lossy(&Command::new("id").arg("-un").output().unwrap().stdout)
            .trim()
            .to_string();
        let (ctld, slurmd) = free_ports();
        let conf = format!(
            "ClusterName=twintrace\n\
             SlurmctldHost={name}(127.0.0.1)\n\
             SlurmctldPort={ctld}\n\
             SlurmdPort={slurmd}\n\
             AuthType=auth/munge\n\
             CredType=cred/munge\n\
             AuthInfo=socket={socket}\n\
             SlurmUser={user}\n\
             SlurmdUser={user}\n\
             StateSaveLocation={d}/state\n\
             SlurmdSpoolDir={d}/spool\n\
             SlurmctldPidFile={d}/slurmctld.pid\n\
             SlurmdPidFile={d}/slurmd.pid\n\
             SlurmctldLogFile={d}/slurmctld.log\n\
             SlurmdLogFile={d}/slurmd.log\n\
             ProctrackType=proctrack/linuxproc\n\
             TaskPlugin=task/none\n\
             JobAcctGatherType=jobacct_gather/none\n\
             AccountingStorageType=accounting_storage/none\n\
             SelectType=select/cons_tres\n\
             SelectTypeParameters=CR_Core\n\
             MpiDefault=none\n\
             ReturnToService=2\n\
             {node} NodeAddr=127.0.0.1 State=UNKNOWN\n\
             PartitionName=main Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n",
            socket = socket.display(),
            d = d.display(),
        );
        std::fs::write(d.join("slurm.conf"), conf).unwrap();
        for (daemon, args) in [("slurmctld", &["-D", "-c"][..]), ("slurmd", &["-D"][..])] {
            let log = std::fs::File::create(d.join(format!("{daemon}.out"))).unwrap();
            let child = cluster
                .command(daemon)
                .args(args)
                .stdin(Stdio::null())
                .stdout(log.try_clone().unwrap())
                .stderr(log)
                .spawn()
                .unwrap_or_else(|e| panic!("{daemon} starts: {e}"));
            cluster.daemons.push(child);
        }
        cluster.wait_for("the node to be idle", || {
            cluster
                .command("sinfo")
                .args(["-h", "-o", "%t"])
                .output()
                .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "idle")
        });
        cluster
    }

    /// One of Slurm's programs, pointed at this cluster's configuration.
    fn command(&self, name: &str) -> Command {
        let mut c = Command::new(program(name));
        c.env("SLURM_CONF", self.dir.path().join("slurm.conf"));
        c
    }

    /// Runs one of Slurm's programs to its end; panics with its output and
    /// the daemons' logs when it fails.
    fn run(&self, name: &str, args: &[&str], env: &[(&str, &Path)]) -> String {
        let mut c = self.command(name);
        c.args(args).stdin(Stdio::null());
        // Submitted from the repository root, as docs/split-renders.md says.
        c.current_dir(twintrace::compare::gate::workspace_root());
        for (k, v) in env {
            c.env(k, v);
        }
        let o = c.output().unwrap();
        assert!(
            o.status.success(),
            "{name} {}: {}\n{}",
            args.join(" "),
            text(&o),
            self.logs()
        );
        String::from_utf8_lossy(&o.stdout).trim().to_string()
    }

    /// `scontrol show job ID`'s `Key=Value` fields, one job record a map.
    fn jobs(&self, id: &str) -> Vec<Vec<(String, String)>> {
        let out = self.run("scontrol", &["-o", "show", "job", id], &[]);
        out.lines()
            .map(|l| {
                l.split_whitespace()
                    .filter_map(|f| f.split_once('='))
                    .map(|(k, v)| (k.to_string(), v.to_string()))
                    .collect()
            })
            .collect()
    }

    fn field<'a>(job: &'a [(String, String)], key: &str) -> &'a str {
        job.iter()
            .find(|(k, _)| k == key)
            .map_or("", |(_, v)| v.as_str())
    }

    /// Waits until `done` holds; panics with the daemons' logs after
    /// [`DEADLINE`].
    fn wait_for(&self, what: &str, mut done: impl FnMut() -> bool) {
        let start = Instant::now();
        while !done() {
            assert!(
                start.elapsed() < DEADLINE,
                "waited {DEADLINE:?} for {what}\n{}",
                self.logs()
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// The daemons' logs and the jobs' outputs, for a failure's message.
    fn logs(&self) -> String {
        let mut s = String::new();
        let mut files: Vec<PathBuf> = std::fs::read_dir(self.dir.path())
            .unwrap()
            .chain(
                std::fs::read_dir(self.dir.path().join("jobs"))
                    .into_iter()
                    .flatten(),
            )
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "log" || x == "out"))
            .collect();
        files.sort();
        for f in files {
            let t = std::fs::read_to_string(&f).unwrap_or_default();
            let tail: Vec<&str> = t.lines().rev().take(15).collect();
            s += &format!("--- {}\n", f.display());
            for l in tail.into_iter().rev() {
                s += l;
                s.push('\n');
            }
        }
        s
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        for d in self.daemons.iter_mut().rev() {
            let _ = d.kill();
            let _ = d.wait();
        }
    }
}

#[test]
fn the_slurm_recipe_renders_an_array_resubmits_a_failed_task_and_merges_bit_for_bit() {
    let cluster = Cluster::start();
    let d = cluster.dir.path();
    let scene = tiny_scene(d);
    let o = twintrace(
        d,
        &[
            "render",
            &scene.display().to_string(),
            "--backend",
            "cpu",
            "-o",
            "whole",
        ],
    );
    assert!(o.ok, "{}", o.stderr);
    let whole = layer_bits(&read_exr(&d.join("whole.exr")).unwrap());

    // The binary the tasks run ($TWINTRACE, which part.sh reads) fails
    // once for task 1, as a lost node would; then it is twintrace.
    let marker = d.join("fail-once");
    std::fs::write(&marker, "").unwrap();
    let flaky = d.join("flaky-twintrace");
    std::fs::write(
        &flaky,
        format!(
            "#!/bin/sh\n\
             if [ \"$SLURM_ARRAY_TASK_ID\" = 1 ] && rm {marker} 2>/dev/null; then\n\
             \x20   echo 'task 1: failing once' >&2; exit 1\n\
             fi\n\
             exec {bin} \"$@\"\n",
            marker = marker.display(),
            bin = common::twintrace_bin().display(),
        ),
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&flaky, std::fs::Permissions::from_mode(0o755)).unwrap();

    let jobs = d.join("jobs");
    std::fs::create_dir(&jobs).unwrap();
    let parts = d.join("parts");
    let out = d.join("render");
    let root = twintrace::compare::gate::workspace_root();
    let recipe = |name: &str| {
        root.join("docs/recipes/slurm")
            .join(name)
            .display()
            .to_string()
    };
    // The job's logs (the scripts' relative --output) go to `jobs`, not
    // into the repository.
    let chdir = format!("--chdir={}", jobs.display());
    let array_export = format!(
        "--export=ALL,SCENE={},SPP=24,PARTS=3,OUTDIR={}",
        scene.display(),
        parts.display()
    );
    let env = [("TWINTRACE", flaky.as_path())];
    let submit_parts = |array: &str| {
        cluster.run(
            "sbatch",
            &[
                "--parsable",
                array,
                &chdir,
                &array_export,
                &recipe("parts.sbatch"),
            ],
            &env,
        )
    };
    let array = submit_parts("--array=0-2");
    let merge = cluster.run(
        "sbatch",
        &[
            "--parsable",
            &format!("--dependency=afterok:{array}"),
            &chdir,
            &format!(
                "--export=ALL,PARTS=3,OUTDIR={},OUT={}",
                parts.display(),
                out.display()
            ),
            &recipe("merge.sbatch"),
        ],
        &env,
    );

    // The array ends with task 1 failed; the merge can never start.
    cluster.wait_for("the array to end and the merge to be stuck", || {
        let tasks = cluster.jobs(&array);
        let m = cluster.jobs(&merge);
        tasks.len() == 3
            && tasks
                .iter()
                .all(|t| matches!(Cluster::field(t, "JobState"), "COMPLETED" | "FAILED"))
            && Cluster::field(&m[0], "Reason") == "DependencyNeverSatisfied"
    });
    let mut states: Vec<(String, String)> = cluster
        .jobs(&array)
        .iter()
        .map(|t| {
            (
                Cluster::field(t, "ArrayTaskId").to_string(),
                Cluster::field(t, "JobState").to_string(),
            )
        })
        .collect();
    states.sort();
    let expected = [("0", "COMPLETED"), ("1", "FAILED"), ("2", "COMPLETED")];
    assert_eq!(
        states,
        expected.map(|(a, b)| (a.to_string(), b.to_string())),
        "{}",
        cluster.logs()
    );
    assert!(
        !parts.join("part-1.exr").exists(),
        "a failed task writes no part"
    );
    assert_eq!(
        Cluster::field(&cluster.jobs(&merge)[0], "JobState"),
        "PENDING"
    );

    // The failed task alone, and the merge after it (docs/split-renders.md).
    let again = submit_parts("--array=1");
    cluster.run(
        "scontrol",
        &[
            "update",
            &format!("JobId={merge}"),
            &format!("Dependency=afterok:{again}"),
        ],
        &[],
    );
    cluster.wait_for("the merge to end", || {
        matches!(
            Cluster::field(&cluster.jobs(&merge)[0], "JobState"),
            "COMPLETED" | "FAILED" | "CANCELLED" | "TIMEOUT"
        )
    });
    assert_eq!(
        Cluster::field(&cluster.jobs(&merge)[0], "JobState"),
        "COMPLETED",
        "{}",
        cluster.logs()
    );
    let merged = layer_bits(&read_exr(&out.with_extension("exr")).unwrap());
    let differ = merged.iter().zip(&whole).filter(|(a, b)| a != b).count();
    assert!(
        merged.len() == whole.len() && differ == 0,
        "the merged parts are not the whole render: {differ} of {} words differ",
        whole.len()
    );
}
