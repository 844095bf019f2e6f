//! `make bench` (rendering): the demo forest (the fixture trees at 32 cells, about 20,000 of
//! them on the fixture mountain), framed as `make demo` frames it:
//!
//! - the demo frame at 1920 x 1080, 1 sample per pixel, texel method: seconds, volume samples
//!   per pixel, and volume samples per second per core next to the limit, a trilinear lookup
//!   marching a 32^3 texture in this process (the ratio says how far the renderer is from the
//!   memory system);
//! - the near view (`--eye -60,260,480 --target 0,240,300`, 960 x 540, 1 spp): seconds and
//!   volume samples per pixel;
//! - the demo frame at 1280 x 720, 16 spp, mesh method: seconds and samples per second;
//! - the hybrid method against both pure methods on the demo frame and the near view, 1 spp
//!   (no baseline: older builds have no hybrid method);
//! - shadow rays from the sun-depth cache (`--shadows cached`, the default) against exact
//!   ones, the demo frame at 1920 x 1080 (the cached side is the first row's runs) and 640 x
//!   360, 1 spp: seconds, grids built, peak memory (no baseline: older builds have no cache).
//!
//! Every figure is the median of 3 whole `texel render` runs. With `TEXEL_BASELINE=path` (the
//! `texel` binary of another build, e.g. the previous commit's) each run of this build is
//! paired with one of that build on the same inputs, in turn, and the ratio printed: speed
//! claims are ratios measured in the same run.

mod common;

use std::path::{Path, PathBuf};
use std::time::Instant;

use common::{Bench, number_before, root};

use glam::{Vec3, vec3};
use texel_forest::bake::{self, BakeSettings};
use texel_forest::import;

const RUNS: usize = 3;

/// What one whole run printed and took.
#[derive(Clone, Copy, Default)]
struct Run {
    seconds: f64,
    samples_per_pixel: f64,
    shadow_rays_per_pixel: f64,
    /// Sun-depth grids built, and the process's peak memory (MiB).
    grids: f64,
    peak_mib: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn render(bench: &Bench, texel: &Path, args: &[&str]) -> Run {
    let mut all = vec!["render"];
    all.extend_from_slice(args);
    let (seconds, err) = bench.run_binary(texel, &all);
    Run {
        seconds,
        samples_per_pixel: number_before(&err, "volume samples").unwrap_or(0.0),
        shadow_rays_per_pixel: number_before(&err, "shadow rays per pixel").unwrap_or(0.0),
        grids: number_before(&err, "sun-depth grids").unwrap_or(0.0),
        peak_mib: err
            .split("peak memory ")
            .nth(1)
            .and_then(|t| t.split_whitespace().next()?.parse().ok())
            .unwrap_or(0.0),
    }
}

/// Medians of `RUNS` runs of this build, and of the baseline's where given, run in turn.
fn measure(bench: &Bench, baseline: Option<&Path>, args: &[&str]) -> (Run, Option<Run>) {
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for _ in 0..RUNS {
        a.push(render(bench, &bench.texel, args));
        if let Some(base) = baseline {
            b.push(render(bench, base, args));
        }
    }
    let med = |runs: &[Run]| Run {
        seconds: median(runs.iter().map(|r| r.seconds).collect()),
        samples_per_pixel: median(runs.iter().map(|r| r.samples_per_pixel).collect()),
        shadow_rays_per_pixel: median(runs.iter().map(|r| r.shadow_rays_per_pixel).collect()),
        grids: median(runs.iter().map(|r| r.grids).collect()),
        peak_mib: median(runs.iter().map(|r| r.peak_mib).collect()),
    };
    (med(&a), (!b.is_empty()).then(|| med(&b)))
}

fn versus(a: f64, b: Option<f64>) -> String {
    b.map_or(String::new(), |b| {
        format!("  (baseline {b:.2}: {:.2}x faster)", b / a)
    })
}

/// Trilinear lookups per second on one core marching the fixture broadleaf at 32 cells along
/// random rays, one lookup per cell: the memory system's limit for a texture march.
fn trilinear_limit(root: &Path) -> f64 {
    let model = import::load(&root.join("fixtures/trees/broadleaf.gltf")).expect("fixture");
    let texel = bake::bake(&model.mesh, &BakeSettings::default()).expect("bakes");
    let level = &texel.levels[0];
    let dims = Vec3::from(level.dims.map(|d| d as f32));
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut unit = move || {
        state = texel_forest::rng::mix64(state);
        texel_forest::rng::unit(state) as f32
    };
    let rays: Vec<(Vec3, Vec3)> = (0..20_000)
        .map(|_| {
            let a = vec3(unit(), unit(), unit()) * dims;
            let b = vec3(unit(), unit(), unit()) * dims;
            (a, (b - a).normalize_or(Vec3::X))
        })
        .collect();
    let (mut lookups, mut sum) = (0u64, 0.0f32);
    let start = Instant::now();
    while start.elapsed().as_secs_f64() < 1.0 {
        for &(o, d) in &rays {
            let mut c = o;
            while c.cmpge(Vec3::ZERO).all() && c.cmple(dims).all() {
                sum += level.fetch(c).density[1];
                c += d;
                lookups += 1;
            }
        }
    }
    std::hint::black_box(sum);
    lookups as f64 / start.elapsed().as_secs_f64()
}

fn main() {
    let bench = Bench::new("render");
    let baseline: Option<PathBuf> = std::env::var_os("TEXEL_BASELINE").map(PathBuf::from);
    std::fs::copy(
        root().join("fixtures/species/forest.json"),
        bench.dir.join("species.json"),
    )
    .expect("copy");
    bench.bake_fixture_trees();
    bench.run(&[
        "place",
        root()
            .join("fixtures/terrain/mountain.glb")
            .to_str()
            .expect("UTF-8 path"),
        "--species",
        "species.json",
        "-o",
        "forest.instances",
        "-q",
    ]);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!(
        "cores: {cores}; medians of {RUNS} whole runs{}",
        baseline
            .as_ref()
            .map_or(String::new(), |b| format!("; baseline {}", b.display()))
    );
    let base = baseline.as_deref();
    let limit = trilinear_limit(root());

    let demo = [
        "forest.instances",
        "-o",
        "demo.exr",
        "--width",
        "1920",
        "--height",
        "1080",
    ];
    // The pure methods are asked for by name: the default is the hybrid.
    let texel = |frame: &[&'static str]| [frame, &["--method", "texel"]].concat();
    let (a, b) = measure(&bench, base, &texel(&demo));
    let demo_run = a;
    let per_core = a.samples_per_pixel * 1920.0 * 1080.0 / a.seconds / cores as f64;
    println!(
        "demo frame 1920x1080, 1 spp, texel  {:>7.2} s  {:>5.1} volume samples and {:.1} shadow rays per pixel{}",
        a.seconds,
        a.samples_per_pixel,
        a.shadow_rays_per_pixel,
        versus(a.seconds, b.map(|b| b.seconds))
    );
    println!(
        "  {:.2e} volume samples per second per core; trilinear lookups marching a 32^3 texture: {limit:.2e} per second on one core ({:.1}% of the limit)",
        per_core,
        100.0 * per_core / limit
    );

    let near = [
        "forest.instances",
        "-o",
        "near.exr",
        "--eye",
        "-60,260,480",
        "--target",
        "0,240,300",
        "--width",
        "960",
        "--height",
        "540",
    ];
    let (a, b) = measure(&bench, base, &texel(&near));
    println!(
        "near view 960x540, 1 spp, texel      {:>7.2} s  {:>5.1} volume samples per pixel{}{}",
        a.seconds,
        a.samples_per_pixel,
        b.map_or(String::new(), |b| format!(
            " (baseline {:.1})",
            b.samples_per_pixel
        )),
        versus(a.seconds, b.map(|b| b.seconds))
    );

    let mesh = [
        "forest.instances",
        "-o",
        "mesh.exr",
        "--width",
        "1280",
        "--height",
        "720",
        "--method",
        "mesh",
        "--spp",
        "16",
    ];
    let (a, b) = measure(&bench, base, &mesh);
    println!(
        "demo frame 1280x720, 16 spp, mesh   {:>7.2} s  {:.2e} samples per second{}",
        a.seconds,
        16.0 * 1280.0 * 720.0 / a.seconds,
        versus(a.seconds, b.map(|b| b.seconds))
    );

    // The sun-depth cache pays only where enough shadow rays read each grid: both sizes.
    for (w, h) in [("1920", "1080"), ("640", "360")] {
        let frame = [
            "forest.instances",
            "-o",
            "shadows.exr",
            "--width",
            w,
            "--height",
            h,
            "--method",
            "texel",
        ];
        let time = |shadows: &str| {
            let mut args = frame.to_vec();
            args.extend_from_slice(&["--shadows", shadows]);
            measure(&bench, None, &args).0
        };
        // The demo row's runs are this frame's, cached by default.
        let cached = if w == "1920" {
            demo_run
        } else {
            time("cached")
        };
        let exact = time("exact");
        println!(
            "demo frame {w}x{h}, 1 spp, texel: --shadows cached {:.2} s ({:.0} grids, peak {:.0} MiB), exact {:.2} s (peak {:.0} MiB): {:.2}x",
            cached.seconds,
            cached.grids,
            cached.peak_mib,
            exact.seconds,
            exact.peak_mib,
            exact.seconds / cached.seconds
        );
    }

    for (name, frame) in [
        ("demo frame 1920x1080", &demo[..]),
        ("near view 960x540", &near[..]),
    ] {
        let time = |method: &str| {
            let mut args = frame.to_vec();
            args.extend_from_slice(&["--method", method]);
            measure(&bench, None, &args).0
        };
        let (texel, mesh, hybrid) = (time("texel"), time("mesh"), time("hybrid"));
        println!(
            "{name}, 1 spp: hybrid {:.2} s ({:.1} volume samples per pixel), texel {:.2} s, mesh {:.2} s",
            hybrid.seconds, hybrid.samples_per_pixel, texel.seconds, mesh.seconds
        );
    }
}
