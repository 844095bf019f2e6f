//! Reading input files with a bound on their size. An input may be anything a user names: a
//! FIFO, `/dev/zero`, a file growing while we read. Every read stops at what its format allows,
//! so no input can make us allocate without limit.

use std::io::Read;
use std::path::{Path, PathBuf};

/// Largest glTF file (`.gltf` JSON or `.glb` with its binary chunk).
pub const MAX_GLTF: u64 = 1 << 30;
/// Largest image a glTF may name.
pub const MAX_IMAGE: u64 = 256 << 20;
/// Largest species file.
pub const MAX_SPECIES: u64 = 16 << 20;

#[derive(Debug, thiserror::Error)]
pub enum InputError {
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: larger than the {limit} bytes a {what} may have")]
    TooLarge {
        path: PathBuf,
        limit: u64,
        what: &'static str,
    },
}

/// What tells one input file from another however its path is spelt (`a/../b.texel` is
/// `b.texel`, and so is a link to it): the canonical path where the file exists, else the path
/// as given (whose read then fails with its own error). Caches of decoded inputs are keyed by
/// it, so that a file named many ways is decoded once.
pub fn file_key(path: &Path) -> std::path::PathBuf {
    std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf())
}

/// The whole of `path`, refused if it holds more than `limit` bytes (`what` names the kind of
/// file in the message). Never reads more than `limit + 1` bytes.
pub fn read_bounded(path: &Path, limit: u64, what: &'static str) -> Result<Vec<u8>, InputError> {
    let io = |source| InputError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    // A regular file says its size: refuse it before reading anything.
    if let Ok(m) = file.metadata()
        && m.is_file()
        && m.len() > limit
    {
        return Err(InputError::TooLarge {
            path: path.to_path_buf(),
            limit,
            what,
        });
    }
    let mut bytes = Vec::new();
    file.take(limit + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > limit {
        return Err(InputError::TooLarge {
            path: path.to_path_buf(),
            limit,
            what,
        });
    }
    Ok(bytes)
}

/// The first `n` bytes of `path` (fewer if it is shorter), then the rest up to `total` bytes in
/// all, where `total` is decided from the first `n` (`None`: stop there). For formats whose
/// first bytes say how long the file is: a file that is not of the format is judged by its
/// first bytes, not read whole.
pub fn read_framed(
    path: &Path,
    n: usize,
    total: impl FnOnce(&[u8]) -> Option<u64>,
) -> Result<Vec<u8>, InputError> {
    let io = |source| InputError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut file = std::fs::File::open(path).map_err(io)?;
    let mut bytes = Vec::new();
    (&mut file)
        .take(n as u64)
        .read_to_end(&mut bytes)
        .map_err(io)?;
    if let Some(total) = total(&bytes) {
        // One byte more than promised, so that trailing data is seen (and refused).
        let rest = (total + 1).saturating_sub(bytes.len() as u64);
        file.take(rest).read_to_end(&mut bytes).map_err(io)?;
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endless_inputs_stop_at_the_bound() {
        if !Path::new("/dev/zero").exists() {
            return;
        }
        let e = read_bounded(Path::new("/dev/zero"), 1 << 20, "species file").unwrap_err();
        assert!(
            e.to_string().contains("larger than the 1048576 bytes"),
            "{e}"
        );
        let b = read_framed(Path::new("/dev/zero"), 32, |_| None).unwrap();
        assert_eq!(b.len(), 32);
        let b = read_framed(Path::new("/dev/zero"), 32, |_| Some(100)).unwrap();
        assert_eq!(b.len(), 101);
    }
}
