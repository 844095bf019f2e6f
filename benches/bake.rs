//! `make bench`: bake time of every fixture and real tree at 256 -> 32 and 512 -> 64, and of a
//! procedural 100k-triangle tree (the target: under 1 s at 256 -> 32 on 2 cores).
//!
//! Each figure is the median of several runs of the whole bake (scan, density, albedo, Sobel,
//! mips) after import; encoding and writing the file are timed separately.

use std::time::Instant;

use texel_forest::bake::{self, BakeSettings};
use texel_forest::corpus;
use texel_forest::formats::texel;
use texel_forest::import::{self, Mesh};
use texel_forest::procedural::{builder, trees};

fn median_seconds(runs: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[runs / 2]
}

fn report(name: &str, mesh: &Mesh) {
    for (res, fine) in [(32, 256), (64, 512)] {
        let settings = BakeSettings {
            resolution: res,
            fine,
            ..BakeSettings::default()
        };
        let runs = if mesh.triangles.len() > 50_000 || res == 64 {
            3
        } else {
            5
        };
        let mut baked = None;
        let seconds = median_seconds(runs, || {
            baked = Some(bake::bake(mesh, &settings).expect("bake"))
        });
        let baked = baked.expect("ran");
        let encode = median_seconds(3, || {
            std::hint::black_box(texel::encode(&baked).expect("encodes"));
        });
        let bytes = texel::encode(&baked).expect("encodes").len();
        println!(
            "{name:<26} {:>8} {:>4} -> {:<3} {:>9.3} {:>9.3} {:>10.1}",
            mesh.triangles.len(),
            fine,
            res,
            seconds,
            encode,
            bytes as f64 / 1024.0
        );
    }
}

fn main() {
    // `cargo bench` passes --bench; any other argument filters models by name.
    let filter: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let wanted = |name: &str| filter.is_empty() || filter.iter().any(|f| name.contains(f.as_str()));
    println!("threads: {}", rayon::current_num_threads());
    println!(
        "{:<26} {:>8} {:>11} {:>9} {:>9} {:>10}",
        "model", "tris", "fine -> res", "bake s", "encode s", "KiB"
    );

    let mut models = corpus::fixture_trees();
    match corpus::real_trees() {
        Some(real) => models.extend(real),
        None => println!("(../shared/realdata absent: real trees skipped)"),
    }
    for path in models {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        if !wanted(&name) {
            continue;
        }
        let model = import::load(&path).expect("fixture imports");
        report(&name, &model.mesh);
    }

    if wanted("procedural-100k") {
        let shape = trees::Deciduous {
            height: 12.0,
            depth: 5,
            children: 3,
            leaves_per_twig: 100,
        };
        let files = trees::deciduous(7, shape).to_gltf(None, "bench");
        let dir = std::env::temp_dir().join(format!("texel-bench-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("big.glb");
        std::fs::write(&path, builder::glb(&files.doc, &files.bin)).expect("write");
        let model = import::load(&path).expect("imports");
        report("procedural-100k", &model.mesh);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
