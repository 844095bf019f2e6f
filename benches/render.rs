//! `make bench` (rendering): the demo forest (the fixture trees at 32 cells, about 20,000 of
//! them on the fixture mountain) at 1280 x 720, 1 sample per pixel, framed as `make demo`
//! frames it. Prints seconds and primary rays per second (target: under 30 s); then the same
//! frame drawn from the polygon models (`--method mesh`) at 16 samples per pixel.

use std::process::Command;
use std::time::Instant;

fn main() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let texel = root.join("target/release/texel");
    let build = Command::new(env!("CARGO"))
        .args(["build", "--release", "--bin", "texel"])
        .current_dir(root)
        .status()
        .expect("cargo runs");
    assert!(build.success());
    let dir = std::env::temp_dir().join(format!("texel-bench-render-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("trees")).expect("temp dir");
    let run = |args: &[&str]| {
        let o = Command::new(&texel)
            .args(args)
            .current_dir(&dir)
            .output()
            .expect("texel runs");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    std::fs::copy(
        root.join("fixtures/species/forest.json"),
        dir.join("species.json"),
    )
    .expect("copy");
    for (tree, name) in [
        ("conifer.glb", "conifer"),
        ("broadleaf.gltf", "broadleaf"),
        ("bare.glb", "bare"),
    ] {
        run(&[
            "bake",
            root.join("fixtures/trees").join(tree).to_str().unwrap(),
            "-o",
            &format!("trees/{name}.texel"),
            "-q",
        ]);
    }
    run(&[
        "place",
        root.join("fixtures/terrain/mountain.glb").to_str().unwrap(),
        "--species",
        "species.json",
        "-o",
        "forest.instances",
        "-q",
    ]);
    println!(
        "threads: {}",
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    let time = |extra: &[&str]| {
        let mut args = vec![
            "render",
            "forest.instances",
            "-o",
            "forest.exr",
            "--width",
            "1280",
            "--height",
            "720",
            "-q",
        ];
        args.extend_from_slice(extra);
        let start = Instant::now();
        run(&args);
        start.elapsed().as_secs_f64()
    };
    let seconds = time(&[]);
    println!(
        "render 1280x720, 1 spp, demo forest, texel method  {seconds:>7.2} s  {:>9.0} primary rays/s  (target < 30 s)",
        1280.0 * 720.0 / seconds
    );
    let seconds = time(&["--method", "mesh", "--spp", "16"]);
    println!(
        "render 1280x720, 16 spp, demo forest, mesh method  {seconds:>7.2} s  {:>9.0} primary rays/s",
        16.0 * 1280.0 * 720.0 / seconds
    );
    let _ = std::fs::remove_dir_all(&dir);
}
