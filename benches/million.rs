//! `make bench` (a million trees): the fixture species at 72% of their spacing on a
//! procedural mountain 5.5 km across, placed by `texel place` up to 1,000,000 trees, then
//! rendered at 1920 x 1080, 1 sample per pixel, with the texel method, framed as `texel render`
//! frames a forest by default. Prints the placement's time and file size, and the render's
//! time, its scene building (the instance and terrain hierarchies), and its peak memory
//! (targets: 60 s and 4 GiB). One run each: whole processes, timed from outside. The
//! picture is left at `target/million.png`.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use texel_forest::procedural::{builder, terrain};

/// The number just after `before` in `text` (the summary line's figures).
fn number_after(text: &str, before: &str) -> Option<f64> {
    let tail = &text[text.find(before)? + before.len()..];
    tail.split_whitespace().next()?.parse().ok()
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let texel = root.join("target/release/texel");
    let build = Command::new(env!("CARGO"))
        .args(["build", "--release", "--bin", "texel"])
        .current_dir(root)
        .status()
        .expect("cargo runs");
    assert!(build.success());
    let dir = std::env::temp_dir().join(format!("texel-bench-million-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("trees")).expect("temp dir");
    let run = |args: &[&str]| -> (f64, String) {
        let start = Instant::now();
        let o = Command::new(&texel)
            .args(args)
            .current_dir(&dir)
            .output()
            .expect("texel runs");
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{err}");
        (start.elapsed().as_secs_f64(), err)
    };
    for (tree, name) in [
        ("conifer.glb", "conifer"),
        ("broadleaf.gltf", "broadleaf"),
        ("bare.glb", "bare"),
    ] {
        let model = root.join("fixtures/trees").join(tree);
        let out = format!("trees/{name}.texel");
        run(&["bake", model.to_str().unwrap(), "-o", &out, "-q"]);
    }
    // A young, dense stand: the fixture's species at 72% of their spacing.
    let mut species: serde_json::Value = serde_json::from_slice(
        &std::fs::read(root.join("fixtures/species/forest.json")).expect("fixture species"),
    )
    .expect("JSON");
    for s in species["species"].as_array_mut().expect("species") {
        let spacing = s["spacing"].as_f64().expect("spacing");
        s["spacing"] = serde_json::json!(spacing * 0.72);
    }
    std::fs::write(dir.join("species.json"), species.to_string()).expect("write");
    let files = terrain::mountain(5500.0, 257, 11).to_gltf(None, "bench");
    std::fs::write(
        dir.join("mountain.glb"),
        builder::glb(&files.doc, &files.bin),
    )
    .expect("write");

    let (place, _) = run(&[
        "place",
        "mountain.glb",
        "--species",
        "species.json",
        "-o",
        "forest.instances",
        "--max-count",
        "1000000",
        "-q",
    ]);
    let bytes = std::fs::metadata(dir.join("forest.instances"))
        .expect("forest")
        .len();
    println!(
        "place 1,000,000 trees on 5.5 km  {place:>7.2} s  file {:.1} MB",
        bytes as f64 / 1e6
    );
    // The picture stays (target/million.png) for a person to look at.
    let preview = root.join("target/million.png");
    let (seconds, err) = run(&[
        "render",
        "forest.instances",
        "-o",
        "forest.exr",
        "--preview",
        preview.to_str().expect("UTF-8 path"),
        "--width",
        "1920",
        "--height",
        "1080",
    ]);
    let figure = |before: &str| number_after(&err, before).unwrap_or(f64::NAN);
    println!(
        "render {} trees at 1920x1080, 1 spp, texel  {seconds:>7.2} s  (scene built in {:.2} s; peak memory {} MiB; {:.1} volume samples per pixel; targets 60 s, 4096 MiB)",
        figure("rendered "),
        figure("scene built in "),
        figure("peak memory "),
        figure("primary rays/s, "),
    );
    println!("  picture: {}", preview.display());
    let _ = std::fs::remove_dir_all(&dir);
}
