//! Running commands, finding the workspace.

use std::io::Write;
use std::path::{Component, Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicU64, Ordering};

/// The checkout `cargo xtask` runs in: `cargo run` (the alias) sets
/// `CARGO_MANIFEST_DIR` for the process, which names it even where the
/// binary was built from another checkout sharing the target folder (the
/// value compiled in would name that one).
pub fn workspace_root() -> PathBuf {
    std::env::var_os("CARGO_MANIFEST_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")))
        .parent()
        .expect("xtask lives one level below the workspace root")
        .to_path_buf()
}

/// The cargo target directory (`CARGO_TARGET_DIR` or `./target`).
pub(crate) fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("target"))
}

/// Runs a program, echoing it; an error says which command failed.
pub fn run(program: &str, args: &[&str]) -> Result<(), String> {
    eprintln!("xtask: {program} {}", args.join(" "));
    let status = Command::new(program)
        .args(args)
        .status()
        .map_err(|e| format!("cannot run {program}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("`{program} {}` failed ({status})", args.join(" ")))
    }
}

/// `apt-get update` then `apt-get install -y` of `packages`, through sudo
/// unless already root.
pub fn apt_install(packages: &[&str]) -> Result<(), String> {
    let root = std::process::Command::new("id")
        .arg("-u")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
        .unwrap_or(false);
    let apt = |args: &[&str]| {
        if root {
            run("apt-get", args)
        } else {
            run("sudo", &[&["apt-get"], args].concat())
        }
    };
    apt(&["update", "-qq"])?;
    apt(&[&["install", "-y", "-qq"], packages].concat())
}

/// An error that refuses what the user asked for (an output that would
/// overwrite an input): `main` exits with status 2 for it, as for a usage
/// error, and 1 for every other failure.
pub fn refused(message: impl std::fmt::Display) -> String {
    format!("{REFUSED}{message}")
}

/// How a refusal's message starts.
pub const REFUSED: &str = "refused: ";

/// A temporary name beside `path` (same folder, so a rename is atomic).
fn temp_beside(path: &Path) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    let unique = COUNTER.fetch_add(1, Ordering::Relaxed);
    path.with_file_name(format!(".{name}.{}-{unique}.tmp", std::process::id()))
}

/// Writes `path` all at once: the bytes go to a temporary file beside it,
/// flushed to disk and renamed into place, so an interrupted write leaves
/// the previous file whole and never a truncated one (what the CLI's
/// `twintrace::image_io::AtomicFile` does; xtask, having no dependencies,
/// does not link it).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), String> {
    put_atomic(path, |tmp| {
        let mut file = std::fs::File::create(tmp)?;
        file.write_all(bytes)?;
        file.sync_all()
    })
}

/// Copies `from` to `to` as [`write_atomic`] writes (the permissions
/// copied too). A copy onto the file itself leaves it as it was.
pub fn copy_atomic(from: &Path, to: &Path) -> Result<(), String> {
    put_atomic(to, |tmp| {
        std::fs::copy(from, tmp)?;
        std::fs::File::open(tmp)?.sync_all()
    })
    .map_err(|e| format!("copying {} to {}: {e}", from.display(), to.display()))
}

/// `fill` writes a temporary file beside `path`, which is then renamed
/// over `path`; on failure the temporary file is removed.
fn put_atomic(path: &Path, fill: impl FnOnce(&Path) -> std::io::Result<()>) -> Result<(), String> {
    let tmp = temp_beside(path);
    let result = fill(&tmp).and_then(|()| std::fs::rename(&tmp, path));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// `path` with links, `.` and `..` resolved: canonical where it exists,
/// else its nearest existing ancestor's canonical path with the rest
/// appended.
pub fn resolve(path: &Path) -> PathBuf {
    if let Ok(p) = std::fs::canonicalize(path) {
        return p;
    }
    let absolute = std::env::current_dir()
        .map(|d| d.join(path))
        .unwrap_or_else(|_| path.to_path_buf());
    let components: Vec<Component> = absolute.components().collect();
    for split in (0..components.len()).rev() {
        let head: PathBuf = components[..split].iter().collect();
        if let Ok(mut p) = std::fs::canonicalize(&head) {
            for c in &components[split..] {
                match c {
                    Component::CurDir => {}
                    Component::ParentDir => {
                        p.pop();
                    }
                    c => p.push(c),
                }
            }
            return p;
        }
    }
    absolute
}

/// Refuses `out` as a folder to fill when it is a file, is one of
/// `inputs` or holds one, or lies inside an input folder (which would be
/// copied into itself). `flag` is the argument as the user gave it.
pub fn check_out_dir(flag: &str, out: &Path, inputs: &[&Path]) -> Result<(), String> {
    if out.exists() && !out.is_dir() {
        return Err(refused(format!(
            "{flag} {}: it is a file, not a folder; name a folder",
            out.display()
        )));
    }
    let o = resolve(out);
    for input in inputs {
        let i = resolve(input);
        if i.starts_with(&o) || (input.is_dir() && o.starts_with(&i)) {
            return Err(refused(format!(
                "{flag} {}: the folder would replace or hold `{}`, which this command reads; name another folder",
                out.display(),
                input.display()
            )));
        }
    }
    Ok(())
}

/// Fills the folder `out` all at once: `fill` writes into a new folder
/// beside it, which then takes `out`'s place (the previous folder is
/// renamed aside first and removed after), so an interrupted run leaves
/// the previous folder whole. `out` is first checked against `inputs`
/// ([`check_out_dir`]).
pub fn replace_dir(
    flag: &str,
    out: &Path,
    inputs: &[&Path],
    fill: impl FnOnce(&Path) -> Result<(), String>,
) -> Result<(), String> {
    check_out_dir(flag, out, inputs)?;
    let out = resolve(out);
    let parent = out.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent).map_err(|e| format!("{}: {e}", parent.display()))?;
    let staging = temp_beside(&out);
    std::fs::create_dir(&staging).map_err(|e| format!("{}: {e}", staging.display()))?;
    if let Err(e) = fill(&staging) {
        let _ = std::fs::remove_dir_all(&staging);
        return Err(e);
    }
    let old = temp_beside(&out);
    let had_old = out.exists();
    if had_old {
        std::fs::rename(&out, &old).map_err(|e| format!("{}: {e}", out.display()))?;
    }
    std::fs::rename(&staging, &out).map_err(|e| format!("{}: {e}", out.display()))?;
    if had_old {
        let _ = std::fs::remove_dir_all(&old);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_writes_replace_whole_files_or_nothing() {
        let dir = std::env::temp_dir().join(format!("xtask-util-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("manifest.txt");
        write_atomic(&file, b"old\n").unwrap();
        write_atomic(&file, b"new\n").unwrap();
        assert_eq!(std::fs::read(&file).unwrap(), b"new\n");
        // A copy onto itself keeps the file (std::fs::copy would truncate it).
        copy_atomic(&file, &file).unwrap();
        assert_eq!(std::fs::read(&file).unwrap(), b"new\n");
        // A failed copy leaves the destination and no temporary file.
        assert!(copy_atomic(&dir.join("missing"), &file).is_err());
        assert_eq!(std::fs::read(&file).unwrap(), b"new\n");
        let names = |d: &Path| {
            let mut n: Vec<String> = std::fs::read_dir(d)
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            n.sort();
            n
        };
        assert_eq!(names(&dir), ["manifest.txt"]);
        // A folder is replaced whole, or kept when filling it fails.
        let pack = dir.join("pack");
        replace_dir("--out", &pack, &[], |d| write_atomic(&d.join("a"), b"1")).unwrap();
        let failed = replace_dir("--out", &pack, &[], |d| {
            write_atomic(&d.join("b"), b"2")?;
            Err("interrupted".into())
        });
        assert_eq!(failed.unwrap_err(), "interrupted");
        assert_eq!(names(&pack), ["a"]);
        replace_dir("--out", &pack, &[], |d| write_atomic(&d.join("c"), b"3")).unwrap();
        assert_eq!(names(&pack), ["c"]);
        assert_eq!(names(&dir), ["manifest.txt", "pack"]);
        // Folders that are, hold or lie inside an input are refused.
        let input = dir.join("pack/c");
        for bad in [
            dir.clone(),
            pack.clone(),
            pack.join("../pack"),
            file.clone(),
        ] {
            let e = replace_dir("--out", &bad, &[&input, &file], |_| Ok(())).unwrap_err();
            assert!(e.starts_with(REFUSED), "{e}");
        }
        let e = replace_dir("--out", &pack.join("inside"), &[&pack], |_| Ok(())).unwrap_err();
        assert!(e.starts_with(REFUSED), "{e}");
        assert_eq!(names(&pack), ["c"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
