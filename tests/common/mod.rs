//! Helpers shared by the end-to-end tests: run the real `texel` binary in a temporary directory.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn texel() -> Command {
    Command::new(env!("CARGO_BIN_EXE_texel"))
}

pub fn run(args: &[&str], dir: &Path) -> Output {
    texel()
        .args(args)
        .current_dir(dir)
        .output()
        .expect("texel runs")
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

pub fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(rel)
}

pub const FIXTURE_TREES: [&str; 3] = [
    "trees/conifer.glb",
    "trees/broadleaf.gltf",
    "trees/bare.glb",
];

/// `../shared/realdata/trees`, or `None` (and a note on stderr) where it is absent.
pub fn realdata_trees() -> Option<Vec<PathBuf>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/realdata/trees");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        eprintln!("skipped: {} is absent", dir.display());
        return None;
    };
    let mut found: Vec<PathBuf> = entries
        .flatten()
        .flat_map(|d| std::fs::read_dir(d.path()).into_iter().flatten().flatten())
        .map(|e| e.path())
        .filter(|p| matches!(p.extension().and_then(|e| e.to_str()), Some("glb" | "gltf")))
        .collect();
    found.sort();
    Some(found)
}

/// Asserts a failed run: exit status 1, exactly one line on stderr that starts with
/// `texel: error:` and contains every `needle`.
pub fn assert_error(o: &Output, needles: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(1), "stderr: {err}");
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| !l.starts_with("texel: warning:"))
        .collect();
    assert_eq!(lines.len(), 1, "one error line expected: {err}");
    assert!(lines[0].starts_with("texel: error: "), "{err}");
    for n in needles {
        assert!(lines[0].contains(n), "{n:?} not in {err:?}");
    }
}
