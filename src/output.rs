//! Writing outputs the way build systems need them: atomically (a reader or an interrupted run
//! never sees a partial file) and with Make-style dependency files.

use std::io::Write;
use std::path::{Path, PathBuf};

/// Writes `bytes` to `path` through a temporary file in the same directory and a rename, so
/// `path` either keeps its old content or has all of the new.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path.file_name().ok_or_else(|| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "output path has no file name",
        )
    })?;
    let tmp = dir.join(format!(
        ".{}.{}.tmp",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Escapes a path for a Make rule: spaces and `#` are backslash-escaped, `$` doubled.
fn make_escape(path: &Path) -> String {
    let mut out = String::new();
    for ch in path.to_string_lossy().chars() {
        match ch {
            ' ' => out.push_str("\\ "),
            '#' => out.push_str("\\#"),
            '$' => out.push_str("$$"),
            c => out.push(c),
        }
    }
    out
}

/// A Make dependency rule: `target: dep dep ...`, one line, newline-terminated.
pub fn depfile(target: &Path, dependencies: &[PathBuf]) -> String {
    let mut line = format!("{}:", make_escape(target));
    for d in dependencies {
        line.push(' ');
        line.push_str(&make_escape(d));
    }
    line.push('\n');
    line
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
            Path::new("out/a.texel"),
            &[PathBuf::from("my tree.gltf"), PathBuf::from("x$#.bin")],
        );
        assert_eq!(line, "out/a.texel: my\\ tree.gltf x$$\\#.bin\n");
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
}
