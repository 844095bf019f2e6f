//! `make bench` (a million trees): the fixture species at 72% of their spacing on a
//! procedural mountain 5.5 km across, placed by `texel place` up to 1,000,000 trees, then
//! rendered at 1920 x 1080, 1 sample per pixel, with the texel method, framed as `texel render`
//! frames a forest by default. Prints the placement's time and file size, and the render's
//! time, its scene building (the instance and terrain hierarchies), and its peak memory
//! (targets: 60 s and 4 GiB). One run each: whole processes, timed from outside. The
//! picture is left at `target/million.png`.

mod common;

use common::{Bench, DENSE_SPACING, mountain_glb, number_after, root};

fn main() {
    let bench = Bench::new("million");
    bench.bake_fixture_trees();
    let mut species: serde_json::Value = serde_json::from_slice(
        &std::fs::read(root().join("fixtures/species/forest.json")).expect("fixture species"),
    )
    .expect("JSON");
    for s in species["species"].as_array_mut().expect("species") {
        let spacing = s["spacing"].as_f64().expect("spacing");
        s["spacing"] = serde_json::json!(spacing * DENSE_SPACING);
    }
    std::fs::write(bench.dir.join("species.json"), species.to_string()).expect("write");
    std::fs::write(bench.dir.join("mountain.glb"), mountain_glb()).expect("write");

    let (place, _) = bench.run(&[
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
    let bytes = std::fs::metadata(bench.dir.join("forest.instances"))
        .expect("forest")
        .len();
    println!(
        "place 1,000,000 trees on 5.5 km  {place:>7.2} s  file {:.1} MB",
        bytes as f64 / 1e6
    );
    // The picture stays (target/million.png) for a person to look at.
    let preview = root().join("target/million.png");
    let (seconds, err) = bench.run(&[
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
        "--method",
        "texel",
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
}
