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

/// The real trees, or `None` (and a note on stderr) where `../shared/realdata` is absent.
pub fn realdata_trees() -> Option<Vec<PathBuf>> {
    let found = texel_forest::corpus::real_trees();
    if found.is_none() {
        eprintln!("skipped: ../shared/realdata/trees is absent");
    }
    found
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

/// The fixture species file in `dir`, and beside it the fixture trees baked coarse (8 cells)
/// where it expects them: the inputs of `place` and `render` tests.
pub fn species_with_texels(dir: &Path) {
    std::fs::copy(fixture("species/forest.json"), dir.join("species.json")).unwrap();
    for tree in FIXTURE_TREES {
        let name = Path::new(tree)
            .file_stem()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        let o = bake_coarse(
            dir,
            fixture(tree).to_str().unwrap(),
            &format!("trees/{name}.texel"),
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
}

/// `texel bake` of `model` to `texel`, coarse (8 cells, 32 fine) as the tests' forests are.
pub fn bake_coarse(dir: &Path, model: &str, texel: &str) -> Output {
    run(
        &[
            "bake",
            model,
            "-o",
            texel,
            "--resolution",
            "8",
            "--fine",
            "32",
        ],
        dir,
    )
}

/// `texel place` on the fixture mountain with `dir`'s species file, to `forest.instances`.
pub fn place_on_mountain(dir: &Path, extra: &[&str]) -> Output {
    place_on("terrain/mountain.glb", dir, extra)
}

/// `texel place` on fixture `terrain` with `dir`'s species file, to `forest.instances`.
pub fn place_on(terrain: &str, dir: &Path, extra: &[&str]) -> Output {
    let terrain = fixture(terrain);
    let mut args = vec![
        "place",
        terrain.to_str().unwrap(),
        "--species",
        "species.json",
        "-o",
        "forest.instances",
    ];
    args.extend_from_slice(extra);
    run(&args, dir)
}

/// The fixture trees baked coarse, the species file, and a forest on a 240 m square in the
/// middle of the mountain, as `forest.instances`.
pub fn small_forest() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    species_with_texels(dir.path());
    let o = place_on_mountain(dir.path(), &["--region=-120,-120,120,120"]);
    assert!(o.status.success(), "{}", stderr(&o));
    dir
}

/// A small view of `small_forest`: 64 x 36 pixels from the south-west, above the trees.
pub const VIEW: [&str; 9] = [
    "--eye=-150,450,260",
    "--target",
    "0,300,0",
    "--width",
    "64",
    "--height",
    "36",
    "--fov",
    "40",
];

/// `texel render forest.instances` in `dir` with [`VIEW`] and `extra`.
pub fn render(dir: &Path, extra: &[&str]) -> Output {
    let mut a = vec!["render", "forest.instances"];
    a.extend_from_slice(&VIEW);
    a.extend_from_slice(extra);
    run(&a, dir)
}
