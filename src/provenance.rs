//! Where a file came from. Our files record the files they were made from, each by path
//! (relative to the recording file) and SHA-256, so a later stage can refuse inputs that
//! changed since: a forest whose terrain was edited, a texture whose model was re-exported.
//! This module records sources and reads files verified against their record.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

use crate::hex::hex;
use crate::input::{self, InputError};
use crate::output::relative_path;

/// A file something was made from: where it is (`P`), its SHA-256 and its size. As a glTF
/// import read it, the path is where it was read (`Source<PathBuf>`); as our files record it,
/// the path is relative to the recording file, `/`-separated ([`SourceFile`]).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, bincode::Encode, bincode::Decode)]
pub struct Source<P = String> {
    pub path: P,
    #[serde(serialize_with = "crate::hex::hex32")]
    pub sha256: [u8; 32],
    pub bytes: u64,
}

/// A source as `.texel` and `.instances` record it (path relative to the recording file).
pub type SourceFile = Source<String>;

pub fn sha256(bytes: &[u8]) -> [u8; 32] {
    Sha256::digest(bytes).into()
}

/// `path`'s record, relative to directory `base` (the directory of the file recording it).
pub fn source(path: &Path, bytes: &[u8], base: &Path) -> SourceFile {
    SourceFile {
        path: relative_path(path, base),
        sha256: sha256(bytes),
        bytes: bytes.len() as u64,
    }
}

/// The records of files an import read, relative to `base`, and the SHA-256 of their
/// concatenated digests (`.texel`'s `inputs_sha256`).
pub fn record(sources: &[Source<PathBuf>], base: &Path) -> (Vec<SourceFile>, [u8; 32]) {
    let mut all = Sha256::new();
    let records = sources
        .iter()
        .map(|s| {
            all.update(s.sha256);
            SourceFile {
                path: relative_path(&s.path, base),
                sha256: s.sha256,
                bytes: s.bytes,
            }
        })
        .collect();
    (records, all.finalize().into())
}

#[derive(Debug, thiserror::Error)]
pub enum ProvenanceError {
    #[error(transparent)]
    Unreadable(#[from] InputError),
    #[error("{path} changed since {since} (sha256 {recorded}... recorded, {now} now)")]
    Changed {
        path: PathBuf,
        /// When it was recorded: "the forest was placed", "it was baked".
        since: &'static str,
        recorded: String,
        now: String,
    },
}

/// What a file on disk says about its record.
pub enum Check {
    Same,
    Changed(ProvenanceError),
    Unreadable(ProvenanceError),
}

/// The bytes of `path` (at most `limit`), refused if their SHA-256 is not `recorded` (when
/// `since`).
pub fn read_verified(
    path: &Path,
    recorded: &[u8; 32],
    since: &'static str,
    limit: u64,
) -> Result<Vec<u8>, ProvenanceError> {
    let bytes = input::read_bounded(path, limit, "recorded source")?;
    verify(path, &bytes, recorded, since)?;
    Ok(bytes)
}

/// Refuses `bytes`, read from `path`, if their SHA-256 is not `recorded` (when `since`).
pub fn verify(
    path: &Path,
    bytes: &[u8],
    recorded: &[u8; 32],
    since: &'static str,
) -> Result<(), ProvenanceError> {
    let now = sha256(bytes);
    if &now != recorded {
        return Err(ProvenanceError::Changed {
            path: path.to_path_buf(),
            since,
            recorded: hex(recorded)[..12].to_string(),
            now: format!("{}...", &hex(&now)[..12]),
        });
    }
    Ok(())
}

/// Every recorded source, found relative to `base`, checked against its record (made when
/// `since`); the paths read, in order, each once. A file recorded again with the same digest
/// (however its path is spelt) is read once: a small forest file could otherwise have a large
/// terrain hashed once for each of thousands of copies of its record.
pub fn verify_all(
    records: &[SourceFile],
    base: &Path,
    since: &'static str,
    limit: u64,
) -> Result<Vec<PathBuf>, ProvenanceError> {
    let mut checked = HashSet::new();
    let mut listed = HashSet::new();
    let mut paths = Vec::new();
    for r in records {
        let path = base.join(&r.path);
        if !checked.insert((input::file_key(&path), r.sha256, r.bytes)) {
            if listed.insert(path.clone()) {
                paths.push(path);
            }
            continue;
        }
        // A file longer than recorded cannot match: read no more than one byte beyond.
        let bound = limit.min(r.bytes.saturating_add(1));
        match read_verified(&path, &r.sha256, since, bound) {
            Err(ProvenanceError::Unreadable(InputError::TooLarge { .. })) => {
                return Err(ProvenanceError::Changed {
                    path: path.clone(),
                    since,
                    recorded: hex(&r.sha256)[..12].to_string(),
                    now: format!("more than {} bytes", r.bytes),
                });
            }
            Err(e) => return Err(e),
            Ok(_) => {
                if listed.insert(path.clone()) {
                    paths.push(path);
                }
            }
        }
    }
    Ok(paths)
}

/// [`read_verified`]'s verdict without failing: for tools that describe files and only warn.
pub fn check(path: &Path, recorded: &[u8; 32], since: &'static str, limit: u64) -> Check {
    match read_verified(path, recorded, since, limit) {
        Ok(_) => Check::Same,
        Err(e @ ProvenanceError::Changed { .. }) => Check::Changed(e),
        Err(e) => Check::Unreadable(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_source_recorded_many_times_is_listed_once_and_a_wrong_copy_still_refused() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("t.bin"), b"terrain").unwrap();
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let record = |path: &str, content: &[u8]| SourceFile {
            path: path.into(),
            sha256: sha256(content),
            bytes: content.len() as u64,
        };
        let mut records = vec![record("t.bin", b"terrain"); 1000];
        records.push(record("sub/../t.bin", b"terrain"));
        let since = "the forest was placed";
        let paths = verify_all(&records, dir.path(), since, 100).unwrap();
        assert_eq!(
            paths,
            [dir.path().join("t.bin"), dir.path().join("sub/../t.bin")]
        );
        records.push(record("t.bin", b"another terrain"));
        let e = verify_all(&records, dir.path(), since, 100).unwrap_err();
        assert!(e.to_string().contains("changed since"), "{e}");
    }

    #[test]
    fn a_changed_file_is_refused_and_an_unchanged_one_read() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.bin");
        std::fs::write(&p, b"terrain").unwrap();
        let recorded = sha256(b"terrain");
        let since = "the forest was placed";
        assert_eq!(
            read_verified(&p, &recorded, since, 100).unwrap(),
            b"terrain"
        );
        std::fs::write(&p, b"terrain, edited").unwrap();
        let e = read_verified(&p, &recorded, since, 100)
            .unwrap_err()
            .to_string();
        assert!(e.contains("changed since the forest was placed"), "{e}");
        assert!(matches!(
            check(&p, &recorded, since, 100),
            Check::Changed(_)
        ));
        assert!(matches!(
            check(&dir.path().join("gone"), &recorded, since, 100),
            Check::Unreadable(_)
        ));
    }
}
