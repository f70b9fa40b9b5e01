//! Outputs that never overwrite a command's inputs or each other.
//!
//! Every file a command writes goes through `twintrace::image_io`'s
//! `AtomicFile` (a temporary file renamed into place), so an interrupted
//! command leaves the previous file whole. What that cannot prevent is an
//! output that *is* one of the inputs (`merge a.exr b.exr -o a`), or two
//! outputs that are one file: [`check`] refuses those before anything is
//! written, in one line naming the argument and the file as the user
//! wrote them ([`Refused`], exit status 2).
//!
//! Two paths name one file when they resolve to the same place: links,
//! `.` and `..` and relative paths resolved (for a file not there yet,
//! its nearest existing folder), and on Unix also when both exist with
//! the same device and inode (a hard link, a case-insensitive file
//! system).

use super::common::Refused;
use std::path::{Component, Path, PathBuf};

/// A file a command reads or writes, and how a refusal names it.
#[derive(Clone, Debug)]
pub struct Named {
    /// For an input, what it is, as in "the part `a.exr`"; for an output,
    /// the argument as the user gave it, as in "-o a".
    what: String,
    /// The file itself (for an output, the derived name: `a.exr`).
    path: PathBuf,
}

/// An input: `what` names it in a refusal, e.g. "the part `a.exr`".
pub fn input(what: impl Into<String>, path: impl Into<PathBuf>) -> Named {
    Named {
        what: what.into(),
        path: path.into(),
    }
}

/// An input named as "the {role} `{path}`".
pub fn input_file(role: &str, path: &Path) -> Named {
    input(format!("the {role} `{}`", path.display()), path)
}

/// An output written to `path` for the argument `arg` as the user gave it
/// (e.g. "-o a" for `a.exr`, or "--report r.html").
pub fn output(arg: impl Into<String>, path: impl Into<PathBuf>) -> Named {
    Named {
        what: arg.into(),
        path: path.into(),
    }
}

impl Named {
    /// "-o a (`a.exr`)", or just the argument when it names the file as
    /// written.
    fn as_output(&self) -> String {
        let file = self.path.display().to_string();
        if self.what.ends_with(&format!(" {file}")) || self.what == file {
            self.what.clone()
        } else {
            format!("{} (`{file}`)", self.what)
        }
    }
}

/// Refuses (exit status 2) an output that names one of `inputs`, or two
/// of `outputs` that name one file.
pub fn check(inputs: &[Named], outputs: &[Named]) -> Result<(), Refused> {
    let ins: Vec<Identity> = inputs.iter().map(|n| Identity::of(&n.path)).collect();
    let outs: Vec<Identity> = outputs.iter().map(|n| Identity::of(&n.path)).collect();
    for (o, out) in outputs.iter().zip(&outs) {
        if let Some(i) = ins.iter().position(|i| i.same(out)) {
            return Err(Refused(format!(
                "{} would overwrite {}; name another output",
                o.as_output(),
                inputs[i].what
            )));
        }
    }
    for (k, (b, b_id)) in outputs.iter().zip(&outs).enumerate() {
        if let Some(a) = outs[..k].iter().position(|a| a.same(b_id)) {
            return Err(Refused(format!(
                "{} and {} are one file; name different outputs",
                outputs[a].as_output(),
                b.as_output()
            )));
        }
    }
    Ok(())
}

/// Where a path leads.
struct Identity {
    resolved: PathBuf,
    /// Device and inode, where the file exists (Unix).
    inode: Option<(u64, u64)>,
}

impl Identity {
    fn of(path: &Path) -> Self {
        #[cfg(unix)]
        let inode = {
            use std::os::unix::fs::MetadataExt;
            std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
        };
        #[cfg(not(unix))]
        let inode = None;
        Identity {
            resolved: resolve(path),
            inode,
        }
    }

    fn same(&self, other: &Identity) -> bool {
        self.resolved == other.resolved
            || matches!((self.inode, other.inode), (Some(a), Some(b)) if a == b)
    }
}

/// `path` with links, `.` and `..` resolved: canonical where it exists,
/// else its nearest existing ancestor's canonical path with the rest
/// appended (`.` dropped, `..` taking one name off).
pub fn resolve(path: &Path) -> PathBuf {
    if let Ok(p) = std::fs::canonicalize(path) {
        return p;
    }
    let absolute = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir()
            .map(|d| d.join(path))
            .unwrap_or_else(|_| path.to_path_buf())
    };
    let components: Vec<Component> = absolute.components().collect();
    // The longest prefix that exists, canonical; then the rest by name.
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_to_one_file_are_one_file() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("a.exr"), b"a").unwrap();
        std::fs::create_dir(d.join("sub")).unwrap();
        let part = [input_file("part", &d.join("a.exr"))];
        for same in [
            d.join("a.exr"),
            d.join("sub/../a.exr"),
            d.join("./a.exr"),
            d.join("missing/../a.exr"),
        ] {
            let e = check(&part, &[output("-o a", &same)]).unwrap_err();
            assert!(e.0.contains("would overwrite the part"), "{}", e.0);
        }
        // Files not there yet: one name, or two.
        let new = d.join("sub/new.exr");
        assert!(check(&part, &[output("-o new", &new)]).is_ok());
        let e = check(
            &[],
            &[
                output("-o x", &new),
                output("--save y", d.join("sub/./z/../new.exr")),
            ],
        )
        .unwrap_err();
        assert!(e.0.contains("are one file"), "{}", e.0);
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(d.join("a.exr"), d.join("link.exr")).unwrap();
            assert!(check(&part, &[output("-o link", d.join("link.exr"))]).is_err());
            std::fs::hard_link(d.join("a.exr"), d.join("hard.exr")).unwrap();
            assert!(check(&part, &[output("-o hard", d.join("hard.exr"))]).is_err());
            std::os::unix::fs::symlink(d.join("sub"), d.join("sublink")).unwrap();
            assert!(check(
                &[input_file("part", &d.join("sub/p.exr"))],
                &[output("-o p", d.join("sublink/p.exr"))]
            )
            .is_err());
        }
    }

    #[test]
    fn a_refusal_names_the_argument_and_the_file() {
        let e = check(
            &[input_file("part", Path::new("a.exr"))],
            &[output("-o a", "a.exr")],
        )
        .unwrap_err();
        assert_eq!(
            e.0,
            "-o a (`a.exr`) would overwrite the part `a.exr`; name another output"
        );
        let e = check(
            &[input_file("run", Path::new("r.json"))],
            &[output("-o r.json", "r.json")],
        )
        .unwrap_err();
        assert_eq!(
            e.0,
            "-o r.json would overwrite the run `r.json`; name another output"
        );
    }
}
