//! Writing outputs the way build systems need them.
//!
//! A run's outputs are planned before any work ([`Outputs::add`]): each is checked against the
//! run's inputs and the other outputs (the same file under two names is refused), its directory
//! is created and probed for writing, and an existing target that is not a regular file is
//! noted. When the work is done, [`Outputs::commit`] writes every output to a temporary file
//! beside its target and renames them all into place only once all have been written, so a
//! failed run leaves every old output as it was and no new one half-written. Devices and FIFOs
//! (`-o /dev/null`) are written directly, never replaced; a symbolic link is followed and its
//! target replaced, so the link stays. Temporary files are removed on failure, on SIGINT,
//! SIGTERM and SIGHUP, and, when a crash strands one, by the next run that writes the same
//! target.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Temporary files that exist right now, for the interrupt handler to remove.
static TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Removes the temporary files of interrupted runs when SIGINT, SIGTERM or SIGHUP arrives,
/// then exits with 130. Call once, early, from a program that writes outputs.
pub fn remove_temporaries_on_interrupt() {
    let _ = ctrlc::set_handler(|| {
        if let Ok(list) = TEMPORARIES.lock() {
            for path in list.iter() {
                let _ = std::fs::remove_file(path);
            }
        }
        // A terminal gone with the SIGHUP cannot take the line; the exit status says it.
        use std::io::Write;
        let _ = writeln!(
            std::io::stderr(),
            "texel: interrupted; no output was written"
        );
        std::process::exit(130);
    });
}

fn register(path: &Path) {
    if let Ok(mut list) = TEMPORARIES.lock() {
        list.push(path.to_path_buf());
    }
}

fn unregister(path: &Path) {
    if let Ok(mut list) = TEMPORARIES.lock() {
        list.retain(|p| p != path);
    }
}

#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{flag} {path}: {why}")]
    Refused {
        flag: String,
        path: PathBuf,
        why: String,
    },
    #[error(
        "{}: a depfile cannot name this file: its name holds a line break, which no Make rule can hold",
        path.display()
    )]
    Unnamable { path: PathBuf },
    #[error("cannot write {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// How a target is written.
#[derive(Debug)]
enum Kind {
    /// Through a temporary file in `final_path`'s directory and a rename onto `final_path`
    /// (the target itself, or the file a symbolic link points to).
    Replace { final_path: PathBuf },
    /// Written in place: a device, a FIFO or a socket, which must not be replaced.
    Direct,
}

#[derive(Debug)]
struct Target {
    flag: String,
    path: PathBuf,
    kind: Kind,
    bytes: Option<Vec<u8>>,
}

/// A handle to one planned output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OutputId(usize);

/// The outputs of one run, planned before the work and committed together after it.
#[derive(Debug)]
pub struct Outputs {
    inputs: Vec<PathBuf>,
    targets: Vec<Target>,
}

/// A path made absolute, with symbolic links resolved as far as the path exists and `.` and
/// `..` resolved after that: two names of one file give the same key.
fn identity(path: &Path) -> PathBuf {
    if let Ok(p) = std::fs::canonicalize(path) {
        return p;
    }
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut key = PathBuf::new();
    for part in absolute.components() {
        match part {
            std::path::Component::CurDir => {}
            std::path::Component::ParentDir => {
                key.pop();
            }
            other => {
                key.push(other);
                if let Ok(real) = std::fs::canonicalize(&key) {
                    key = real;
                }
            }
        }
    }
    key
}

/// The directory `path` is in ("." for a bare name).
fn directory_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// `.NAME.PID.tmp` beside `path`.
fn temporary_for(path: &Path, pid: u32) -> Option<PathBuf> {
    let name = path.file_name()?.to_string_lossy().into_owned();
    Some(directory_of(path).join(format!(".{name}.{pid}.tmp")))
}

/// Whether process `pid` still runs (where the system can tell; elsewhere assume it does).
fn is_running(pid: u32) -> bool {
    if cfg!(target_os = "linux") {
        Path::new("/proc").join(pid.to_string()).exists()
    } else {
        true
    }
}

/// Removes `.NAME.PID.tmp` files beside `path` left by runs that no longer exist (killed with
/// SIGKILL, or by a power cut).
fn sweep_stale_temporaries(path: &Path) {
    let (Some(name), Ok(entries)) = (
        path.file_name().map(|n| n.to_string_lossy().into_owned()),
        std::fs::read_dir(directory_of(path)),
    ) else {
        return;
    };
    let prefix = format!(".{name}.");
    for entry in entries.flatten() {
        let file = entry.file_name().to_string_lossy().into_owned();
        let pid = file
            .strip_prefix(&prefix)
            .and_then(|rest| rest.strip_suffix(".tmp"))
            .and_then(|pid| pid.parse::<u32>().ok());
        if let Some(pid) = pid
            && pid != std::process::id()
            && !is_running(pid)
        {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

impl Outputs {
    /// Outputs of a run that reads `inputs` (more can be added with [`Outputs::add_inputs`]).
    pub fn new(inputs: &[&Path]) -> Outputs {
        Outputs {
            inputs: inputs.iter().map(|p| identity(p)).collect(),
            targets: Vec::new(),
        }
    }

    /// More inputs, found during the work (a glTF's buffers and images): outputs may not be
    /// any of them either.
    pub fn add_inputs<P: AsRef<Path>>(&mut self, inputs: &[P]) -> Result<(), OutputError> {
        for input in inputs {
            let key = identity(input.as_ref());
            if let Some(t) = self.targets.iter().find(|t| identity(&t.path) == key) {
                return Err(refused(
                    t,
                    &format!(
                        "is also an input ({}); it would be overwritten",
                        input.as_ref().display()
                    ),
                ));
            }
            self.inputs.push(key);
        }
        Ok(())
    }

    /// Plans output `path`, named on the command line by `flag`. Refuses a path that is an
    /// input or another output, or a directory; creates its directory and checks that a file
    /// can be written there, so a long run does not end in "cannot create".
    pub fn add(&mut self, flag: &str, path: &Path) -> Result<OutputId, OutputError> {
        let refuse = |why: String| OutputError::Refused {
            flag: flag.to_string(),
            path: path.to_path_buf(),
            why,
        };
        if path.file_name().is_none() {
            return Err(refuse("names a directory, not a file".into()));
        }
        let key = identity(path);
        if self.inputs.contains(&key) {
            return Err(refuse("is also an input; it would be overwritten".into()));
        }
        if let Some(other) = self.targets.iter().find(|t| identity(&t.path) == key) {
            return Err(refuse(format!(
                "is also the output of {} ({}): give each output its own file",
                other.flag,
                other.path.display()
            )));
        }
        let kind = match std::fs::metadata(path) {
            Ok(m) if m.is_dir() => return Err(refuse("is a directory".into())),
            Ok(m) if !m.is_file() => Kind::Direct,
            // A regular file, a link to one, or nothing yet: replaced through a temporary in
            // the directory of the file itself (so a link keeps pointing at it).
            _ => Kind::Replace {
                final_path: resolve_links(path),
            },
        };
        if let Kind::Replace { final_path } = &kind {
            let dir = directory_of(final_path);
            std::fs::create_dir_all(&dir)
                .map_err(|e| refuse(format!("cannot create directory {}: {e}", dir.display())))?;
            sweep_stale_temporaries(final_path);
            let probe = temporary_for(final_path, std::process::id())
                .ok_or_else(|| refuse("names no file".into()))?
                .with_extension("probe");
            std::fs::File::create(&probe)
                .and_then(|_| std::fs::remove_file(&probe))
                .map_err(|e| refuse(format!("cannot write in {}: {e}", dir.display())))?;
        }
        self.targets.push(Target {
            flag: flag.to_string(),
            path: path.to_path_buf(),
            kind,
            bytes: None,
        });
        Ok(OutputId(self.targets.len() - 1))
    }

    /// The bytes output `id` will hold.
    pub fn set(&mut self, id: OutputId, bytes: Vec<u8>) {
        self.targets[id.0].bytes = Some(bytes);
    }

    /// Writes every output that was given bytes: all to temporary files first, devices and
    /// FIFOs directly, then every temporary renamed into place. On any failure the temporaries
    /// are removed and no regular output has changed.
    pub fn commit(self) -> Result<(), OutputError> {
        let mut written: Vec<(PathBuf, &Path)> = Vec::new();
        let result = (|| {
            for t in &self.targets {
                let (Some(bytes), Kind::Replace { final_path }) = (&t.bytes, &t.kind) else {
                    continue;
                };
                let tmp = temporary_for(final_path, std::process::id())
                    .ok_or_else(|| refused(t, "names no file"))?;
                register(&tmp);
                written.push((tmp.clone(), final_path));
                write_synced(&tmp, bytes).map_err(|source| OutputError::Io {
                    path: t.path.clone(),
                    source,
                })?;
            }
            for t in &self.targets {
                if let (Some(bytes), Kind::Direct) = (&t.bytes, &t.kind) {
                    write_in_place(&t.path, bytes).map_err(|source| OutputError::Io {
                        path: t.path.clone(),
                        source,
                    })?;
                }
            }
            for (tmp, final_path) in &written {
                std::fs::rename(tmp, final_path).map_err(|source| OutputError::Io {
                    path: final_path.to_path_buf(),
                    source,
                })?;
                unregister(tmp);
            }
            Ok(())
        })();
        if result.is_err() {
            for (tmp, _) in &written {
                let _ = std::fs::remove_file(tmp);
                unregister(tmp);
            }
        }
        result
    }
}

fn refused(t: &Target, why: &str) -> OutputError {
    OutputError::Refused {
        flag: t.flag.clone(),
        path: t.path.clone(),
        why: why.to_string(),
    }
}

/// The file a path names once its symbolic links are followed (a link to a file that does not
/// exist yet resolves to where the file would be).
fn resolve_links(path: &Path) -> PathBuf {
    let mut p = path.to_path_buf();
    for _ in 0..40 {
        match std::fs::read_link(&p) {
            Ok(target) => p = directory_of(&p).join(target),
            Err(_) => return p,
        }
    }
    p
}

fn write_synced(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = std::fs::File::create(path)?;
    f.write_all(bytes)?;
    f.sync_all()
}

fn write_in_place(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = std::fs::OpenOptions::new().write(true).open(path)?;
    f.write_all(bytes)?;
    f.flush()
}

/// Writes one file atomically (temporary file and rename): for tools that write a single output
/// and check nothing else.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let mut outputs = Outputs::new(&[]);
    let id = outputs.add("output", path)?;
    outputs.set(id, bytes.to_vec());
    outputs.commit()
}

/// Escapes a path for a Make rule (GNU make, as gcc writes them): spaces, tabs, `#` and `:` are
/// backslash-escaped, a backslash before one of them doubled, `$` doubled; in a target, `%`
/// too. An unescaped `:` among the prerequisites reads as a static pattern rule ("target
/// pattern contains no '%'") and a `%` in a target as a pattern rule; an escaped `%` among
/// the prerequisites keeps its backslash.
/// A line break cannot be escaped: such a path is refused.
fn make_escape(path: &Path, target: bool) -> Result<String, OutputError> {
    let text = path.to_string_lossy();
    if text.contains(['\n', '\r']) {
        return Err(OutputError::Unnamable {
            path: path.to_path_buf(),
        });
    }
    let mut out = String::new();
    let mut backslashes = 0;
    for ch in text.chars() {
        let special = matches!(ch, ' ' | '\t' | '#' | ':') || (target && ch == '%');
        if special {
            // The backslashes before it stand for themselves: doubled, then the escape.
            out.extend(std::iter::repeat_n('\\', backslashes));
            out.push('\\');
        }
        match ch {
            '$' => out.push_str("$$"),
            c => out.push(c),
        }
        backslashes = if ch == '\\' { backslashes + 1 } else { 0 };
    }
    Ok(out)
}

/// A Make dependency rule: `target: dep dep ...`, one line, newline-terminated.
pub fn depfile(target: &Path, dependencies: &[PathBuf]) -> Result<String, OutputError> {
    depfile_for(&[target], dependencies)
}

/// [`depfile`] of several targets made by one run (a frame sequence): `a b c: dep dep ...`.
pub fn depfile_for(targets: &[&Path], dependencies: &[PathBuf]) -> Result<String, OutputError> {
    let names = targets
        .iter()
        .map(|t| make_escape(t, true))
        .collect::<Result<Vec<String>, _>>()?;
    let mut line = format!("{}:", names.join(" "));
    for d in dependencies {
        line.push(' ');
        line.push_str(&make_escape(d, false)?);
    }
    line.push('\n');
    Ok(line)
}

/// `path` relative to directory `base`, with `/` separators; both are made absolute first.
/// Falls back to the absolute path where no relative one exists (different drives).
pub fn relative_path(path: &Path, base: &Path) -> String {
    let abs = |p: &Path| {
        let p = std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
        std::fs::canonicalize(&p).unwrap_or(p)
    };
    let (path, base) = (abs(path), abs(base));
    let p: Vec<_> = path.components().collect();
    let b: Vec<_> = base.components().collect();
    let common = p.iter().zip(&b).take_while(|(x, y)| x == y).count();
    if common == 0 {
        return path.to_string_lossy().replace('\\', "/");
    }
    let mut parts: Vec<String> = vec!["..".to_string(); b.len() - common];
    parts.extend(
        p[common..]
            .iter()
            .map(|c| c.as_os_str().to_string_lossy().into_owned()),
    );
    if parts.is_empty() {
        ".".to_string()
    } else {
        parts.join("/")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depfile_escapes_make_specials() {
        let line = depfile(
            Path::new("out/a%b.texel"),
            &[
                PathBuf::from("my tree.gltf"),
                PathBuf::from("x$#.bin"),
                PathBuf::from("c:d%e.png"),
                PathBuf::from("r\\ s.png"),
                PathBuf::from("t\tu.png"),
            ],
        )
        .unwrap();
        assert_eq!(
            line,
            "out/a\\%b.texel: my\\ tree.gltf x$$\\#.bin c\\:d%e.png r\\\\\\ s.png t\\\tu.png\n"
        );
        // A line break cannot be escaped (GNU make reads it as the rule's end).
        let e = depfile(Path::new("a.texel"), &[PathBuf::from("a\nb.bin")]).unwrap_err();
        assert!(e.to_string().contains("line break"), "{e}");
    }

    #[test]
    fn relative_paths_climb_out_of_the_base() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("fixtures/trees");
        let b = dir.path().join("out/texels");
        std::fs::create_dir_all(&a).unwrap();
        std::fs::create_dir_all(&b).unwrap();
        std::fs::write(a.join("t.glb"), b"x").unwrap();
        assert_eq!(
            relative_path(&a.join("t.glb"), &b),
            "../../fixtures/trees/t.glb"
        );
    }

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("f.bin");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn an_output_that_is_an_input_or_another_output_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("tree.glb");
        std::fs::write(&input, b"x").unwrap();
        let mut o = Outputs::new(&[&input]);
        // The same file by another name.
        let alias = dir.path().join("sub/../tree.glb");
        std::fs::create_dir_all(dir.path().join("sub")).unwrap();
        let e = o.add("-o", &alias).unwrap_err().to_string();
        assert!(e.contains("is also an input"), "{e}");
        o.add("-o", &dir.path().join("a.texel")).unwrap();
        let e = o
            .add("--depfile", &dir.path().join("a.texel"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("is also the output of -o"), "{e}");
        let e = o
            .add_inputs(&[dir.path().join("a.texel")])
            .unwrap_err()
            .to_string();
        assert!(e.contains("is also an input"), "{e}");
    }

    #[test]
    fn a_failed_commit_changes_no_output() {
        let dir = tempfile::tempdir().unwrap();
        let good = dir.path().join("good.bin");
        std::fs::write(&good, b"old").unwrap();
        let mut o = Outputs::new(&[]);
        let a = o.add("-o", &good).unwrap();
        let b = o.add("--depfile", &dir.path().join("sub/d")).unwrap();
        o.set(a, b"new".to_vec());
        o.set(b, b"dep".to_vec());
        // The depfile's directory vanishes before the commit: nothing may change.
        std::fs::remove_dir(dir.path().join("sub")).unwrap();
        assert!(o.commit().is_err());
        assert_eq!(std::fs::read(&good).unwrap(), b"old");
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "no temporary left: {names:?}");
    }

    #[cfg(unix)]
    #[test]
    fn links_are_followed_and_devices_written_in_place() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.bin");
        std::fs::write(&real, b"old").unwrap();
        let link = dir.path().join("link.bin");
        std::os::unix::fs::symlink("real.bin", &link).unwrap();
        write_atomic(&link, b"new").unwrap();
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        // /dev/null stays a device; /dev/full reports the full disk.
        write_atomic(Path::new("/dev/null"), b"x").unwrap();
        assert!(!std::fs::metadata("/dev/null").unwrap().is_file());
        if Path::new("/dev/full").exists() {
            let e = write_atomic(Path::new("/dev/full"), b"x")
                .unwrap_err()
                .to_string();
            assert!(e.contains("/dev/full"), "{e}");
        }
    }

    #[test]
    fn stale_temporaries_of_dead_runs_are_swept() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("f.bin");
        // PID 2^31 - 2 runs nowhere; our own PID's temporary is not touched.
        let stale = dir.path().join(".f.bin.2147483646.tmp");
        let ours = dir
            .path()
            .join(format!(".f.bin.{}.tmp", std::process::id()));
        let other = dir.path().join(".g.bin.2147483646.tmp");
        for p in [&stale, &ours, &other] {
            std::fs::write(p, b"x").unwrap();
        }
        let mut o = Outputs::new(&[]);
        o.add("-o", &target).unwrap();
        if cfg!(target_os = "linux") {
            assert!(!stale.exists());
        }
        assert!(ours.exists() && other.exists());
    }
}
