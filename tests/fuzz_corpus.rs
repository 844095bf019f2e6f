//! Replays the fuzz corpus kept under `fixtures/fuzz/<target>/` (see `fuzz/README.md`) through
//! exactly the calls of the fuzz target of the same name, and asserts only that nothing panics:
//! a reader may refuse any of these inputs, but must say so with an error.
//!
//! Files named `crash-*`, `timeout-*` or `oom-*` are inputs a fuzzer found to fail; they stay in
//! the corpus as regression tests once fixed.
//!
//! A panic that is not unwound to the caller cannot be caught: exr decodes blocks on a rayon
//! pool of its own, where a panic aborts the process. So every panic is also reported, with the
//! files being replayed, straight to the process's standard error, which the test harness does
//! not capture and an abort does not lose.

use std::io::Write as _;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, Once};

use texel_forest::bake::{BakeSettings, bake};
use texel_forest::compare::Rgba;
use texel_forest::formats::{container, instances, texel};
use texel_forest::import::load_bytes;
use texel_forest::inspect::FileFacts;
use texel_forest::limits::Limits;
use texel_forest::species::SpeciesFile;

fn facts(data: &[u8]) -> FileFacts {
    FileFacts {
        bytes: data.len() as u64,
        minor: 1,
        raw_bytes: 0,
    }
}

/// `fuzz/fuzz_targets/gltf.rs`
fn gltf(data: &[u8]) {
    let path = Path::new("/nonexistent/fuzz.gltf");
    if let Ok(model) = load_bytes(path, data.to_vec(), &Limits::default())
        && !model.mesh.triangles.is_empty()
    {
        let settings = BakeSettings {
            resolution: 8,
            fine: 16,
            ..Default::default()
        };
        let _ = bake(&model.mesh, &settings);
    }
}

/// `fuzz/fuzz_targets/texel.rs`
fn texel(data: &[u8]) {
    if let Ok(t) = texel::decode(data) {
        let _ = texel_forest::inspect::texel::summarize(&t, facts(data));
    }
}

/// `fuzz/fuzz_targets/instances.rs`
fn instances(data: &[u8]) {
    if let Ok(f) = instances::decode_stored(data) {
        let _ = texel_forest::inspect::instances::summarize(&f, facts(data));
    }
}

/// `fuzz/fuzz_targets/species.rs`
fn species(data: &[u8]) {
    let _ = SpeciesFile::parse(data);
}

/// `fuzz/fuzz_targets/exr.rs`
fn exr(data: &[u8]) {
    let _ = Rgba::from_bytes(data, Path::new("fuzz.exr"), &Limits::default());
}

/// The container the `*_raw` targets wrap their input in: `minor: u16 LE, header length:
/// u32 LE, header, raw payload` (`fuzz/fuzz_targets/texel_raw.rs`, `instances_raw.rs`).
fn wrap(magic: &[u8; 8], major: u16, data: &[u8]) -> Option<Vec<u8>> {
    let minor = u16::from_le_bytes(data.get(0..2)?.try_into().ok()?);
    let h = u32::from_le_bytes(data.get(2..6)?.try_into().ok()?) as usize;
    let rest = &data[6..];
    let (header, payload) = rest.split_at(h.min(rest.len()));
    container::write(magic, major, minor, header, payload).ok()
}

/// `fuzz/fuzz_targets/texel_raw.rs`
fn texel_raw(data: &[u8]) {
    if let Some(file) = wrap(texel::MAGIC, texel::MAJOR, data) {
        self::texel(&file);
    }
}

/// `fuzz/fuzz_targets/instances_raw.rs`
fn instances_raw(data: &[u8]) {
    if let Some(file) = wrap(instances::MAGIC, instances::MAJOR, data) {
        self::instances(&file);
    }
}

fn corpus(target: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/fuzz")
        .join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
}

/// The corpus files being replayed right now, one per running test.
static REPLAYING: Mutex<Vec<String>> = Mutex::new(Vec::new());

/// Reports every panic, with the files being replayed, to the uncaptured standard error.
fn report_panics() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let files = REPLAYING
                .try_lock()
                .map(|f| f.join(", "))
                .unwrap_or_default();
            let _ = writeln!(
                std::io::stderr(),
                "fuzz corpus: panic while replaying {files}: {info}"
            );
            default(info);
        }));
    });
}

/// Runs every corpus file of `target` through `run`, each under `catch_unwind`, and fails
/// naming every file that panicked.
fn replay(target: &str, run: fn(&[u8])) {
    report_panics();
    let files = corpus(target);
    assert!(!files.is_empty(), "fixtures/fuzz/{target}/ holds no files");
    let mut panicked = Vec::new();
    for file in &files {
        let name = format!(
            "fixtures/fuzz/{target}/{}",
            file.file_name().unwrap().to_string_lossy()
        );
        let data = std::fs::read(file).unwrap();
        REPLAYING.lock().unwrap().push(name.clone());
        let result = catch_unwind(AssertUnwindSafe(|| run(&data)));
        REPLAYING.lock().unwrap().retain(|f| *f != name);
        if result.is_err() {
            panicked.push(name);
        }
    }
    assert!(
        panicked.is_empty(),
        "{} of {} corpus files of fuzz target {target} panicked (messages above; reproduce one \
         with `cd fuzz && RUSTC_BOOTSTRAP=1 cargo fuzz run {target} ../FILE`):\n  {}",
        panicked.len(),
        files.len(),
        panicked.join("\n  ")
    );
}

#[test]
fn gltf_corpus_does_not_panic() {
    replay("gltf", gltf);
}

#[test]
fn texel_corpus_does_not_panic() {
    replay("texel", texel);
}

#[test]
fn texel_raw_corpus_does_not_panic() {
    replay("texel_raw", texel_raw);
}

#[test]
fn instances_corpus_does_not_panic() {
    replay("instances", instances);
}

#[test]
fn instances_raw_corpus_does_not_panic() {
    replay("instances_raw", instances_raw);
}

#[test]
fn species_corpus_does_not_panic() {
    replay("species", species);
}

#[test]
fn exr_corpus_does_not_panic() {
    replay("exr", exr);
}
