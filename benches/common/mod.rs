//! What the whole-process benchmarks share: the `texel` binary built in release, a scratch
//! directory to run it in, the fixture trees baked there, the million-tree stand, and the
//! figures read back from a run's summary line.

// Each bench uses part of this.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use texel_forest::procedural::{builder, terrain};

/// The fixture species' spacing is multiplied by this for the million-tree stand (a young,
/// dense stand: about 1,024,000 trees on the mountain below).
pub const DENSE_SPACING: f64 = 0.72;

/// The million-tree stand's terrain: a procedural mountain 5.5 km across, as a GLB file.
pub fn mountain_glb() -> Vec<u8> {
    let files = terrain::mountain(5500.0, 257, 11).to_gltf(None, "bench");
    builder::glb(&files.doc, &files.bin)
}

/// The project's root.
pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The `texel` binary of this build, in release, and a scratch directory (with `trees/`)
/// that runs start in.
pub struct Bench {
    pub texel: PathBuf,
    pub dir: PathBuf,
}

impl Bench {
    /// Builds `texel` and makes the scratch directory `texel-bench-{name}-{pid}`.
    pub fn new(name: &str) -> Bench {
        let build = Command::new(env!("CARGO"))
            .args(["build", "--release", "--bin", "texel"])
            .current_dir(root())
            .status()
            .expect("cargo runs");
        assert!(build.success());
        let dir = std::env::temp_dir().join(format!("texel-bench-{name}-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("trees")).expect("temp dir");
        Bench {
            texel: root().join("target/release/texel"),
            dir,
        }
    }

    /// Runs this build's `texel` with `args`: its wall time and what it printed on stderr.
    pub fn run(&self, args: &[&str]) -> (f64, String) {
        self.run_binary(&self.texel, args)
    }

    /// Runs `binary` (this build's or another's) with `args` in the scratch directory.
    pub fn run_binary(&self, binary: &Path, args: &[&str]) -> (f64, String) {
        let start = Instant::now();
        let o = Command::new(binary)
            .args(args)
            .current_dir(&self.dir)
            .output()
            .expect("texel runs");
        let seconds = start.elapsed().as_secs_f64();
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{err}");
        (seconds, err)
    }

    /// Bakes the three fixture trees to `trees/{conifer,broadleaf,bare}.texel`, the names
    /// the fixture species file gives.
    pub fn bake_fixture_trees(&self) {
        for (tree, name) in [
            ("conifer.glb", "conifer"),
            ("broadleaf.gltf", "broadleaf"),
            ("bare.glb", "bare"),
        ] {
            let model = root().join("fixtures/trees").join(tree);
            let out = format!("trees/{name}.texel");
            self.run(&[
                "bake",
                model.to_str().expect("UTF-8 path"),
                "-o",
                &out,
                "-q",
            ]);
        }
    }
}

impl Drop for Bench {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The number just after `before` in `text` (a summary line's figures).
pub fn number_after(text: &str, before: &str) -> Option<f64> {
    let tail = &text[text.find(before)? + before.len()..];
    tail.split_whitespace().next()?.parse().ok()
}

/// The number just before `after` in `text`.
pub fn number_before(text: &str, after: &str) -> Option<f64> {
    let head = &text[..text.find(after)?];
    head.split_whitespace().last()?.parse().ok()
}
