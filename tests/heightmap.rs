//! Heightmap terrains end to end: `place` on the fixture heightmap, `render` from the forest
//! alone (the conversion is recorded), the flags' errors; and the shared real DEM turned into
//! a 16-bit PNG that must agree with its glTF to within the quantisation.

mod common;

use std::path::Path;

use common::*;
use texel_forest::formats::instances;
use texel_forest::terrain::{HeightmapOptions, Terrain};

const SIZE: &str = "--terrain-size=1000,1000";
const RANGE: &str = "--height-range=100,600";

fn place_on_valley(dir: &Path, extra: &[&str]) -> std::process::Output {
    place_on("terrain/valley.png", dir, extra)
}

#[test]
fn place_and_render_on_a_heightmap_without_repeating_the_flags() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    species_with_texels(d);

    // A plain PNG says neither its size nor its heights.
    let o = place_on_valley(d, &[RANGE]);
    assert_error(&o, &["valley.png", "--terrain-size"]);
    let o = place_on_valley(d, &[SIZE]);
    assert_error(&o, &["valley.png", "--height-range"]);
    // A usage error, as clap reports one.
    let o = place_on_valley(d, &[SIZE, "--height-range=600,100"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--height-range") && stderr(&o).contains("LO < HI"));
    // A glTF is already in metres.
    let o = place_on_mountain(d, &[SIZE]);
    assert_error(&o, &["mountain.glb", "--terrain-size"]);

    // The heightmap's north-west sample is at (0, 0): a region inside its 1 km square.
    let o = place_on_valley(d, &[SIZE, RANGE, "--region=380,380,620,620"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let forest = instances::decode(&std::fs::read(d.join("forest.instances")).unwrap()).unwrap();
    assert_eq!(
        forest.heightmap,
        Some(HeightmapOptions {
            size: Some([1000.0, 1000.0]),
            height_range: Some([100.0, 600.0]),
        })
    );
    assert!(forest.info.terrain[0].path.ends_with("valley.png"));
    assert!(!forest.instances.is_empty());
    // Every tree stands on the heightmap's surface (to the centimetre quantisation of x, y, z).
    let terrain = Terrain::load_with(
        &fixture("terrain/valley.png"),
        &forest.heightmap.unwrap(),
        &Default::default(),
    )
    .unwrap();
    assert_eq!(terrain.lo.x, 0.0);
    assert_eq!(terrain.hi.z, 1000.0);
    for p in &forest.instances {
        let ground = terrain.height_at(p.position[0], p.position[2]).unwrap();
        assert!((p.position[1] - ground).abs() < 0.05, "{p:?} vs {ground}");
    }

    // The render rebuilds the terrain from the record alone.
    let view = [
        "--eye=500,650,900",
        "--target=500,300,500",
        "--width=48",
        "--height=27",
        "--spp=2",
    ];
    let mut args = vec!["render", "forest.instances", "-o", "a.exr"];
    args.extend(view);
    let o = run(&args, d);
    assert!(o.status.success(), "{}", stderr(&o));
    // The same terrain given explicitly with its flags draws the same image.
    let valley = fixture("terrain/valley.png");
    let terrain_flag = format!("--terrain={}", valley.display());
    let mut args = vec![
        "render",
        "forest.instances",
        "-o",
        "b.exr",
        &terrain_flag,
        SIZE,
        RANGE,
    ];
    args.extend(view);
    let o = run(&args, d);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(d.join("a.exr")).unwrap(),
        std::fs::read(d.join("b.exr")).unwrap()
    );
    // Converted with other flags it is other ground, and the render says so (still drawing).
    for (size, range, needle) in [
        (
            "--terrain-size=500,500",
            RANGE,
            "does not cover the forest's region",
        ),
        (SIZE, "--height-range=0,60", "but the trees stand from"),
    ] {
        let mut args = vec!["render", "forest.instances", "-o", "c.exr", &terrain_flag];
        args.extend([size, range]);
        args.extend(view);
        let o = run(&args, d);
        assert!(o.status.success(), "{}", stderr(&o));
        let err = stderr(&o);
        assert!(
            err.contains("warning: --terrain") && err.contains(needle),
            "{needle:?} not in {err}"
        );
    }
    // The flags without --terrain would be ignored: refused.
    let mut args = vec!["render", "forest.instances", "-o", "c.exr", SIZE];
    args.extend(view);
    assert_error(&run(&args, d), &["--terrain-size", "forest.instances"]);

    // inspect takes the heightmap as a terrain, and maps the forest over it.
    let o = run(&["inspect", valley.to_str().unwrap(), SIZE, RANGE], d);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(
        &["inspect", "forest.instances", "--map", "-o", "map.png"],
        d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    // The forest's summary says how its terrain was converted.
    let o = run(&["inspect", "forest.instances"], d);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("heightmap     1000 x 1000 m (--terrain-size), heights 100 .. 600 m"),
        "{text}"
    );
    let o = run(&["inspect", "forest.instances", "--json"], d);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(
        json["heightmap"]["height_range"],
        serde_json::json!([100.0, 600.0])
    );
    // export copies glTF terrains' nodes only, and says so of a heightmap.
    let o = run(
        &[
            "export",
            "forest.instances",
            "-o",
            "e.glb",
            "--with-terrain",
        ],
        d,
    );
    assert_error(&o, &["forest.instances", "--with-terrain", "heightmap"]);
    assert!(!d.join("e.glb").exists());
}

/// The shared real DEM (a 257 x 257 glTF grid) sampled at its vertices into a 16-bit PNG reads
/// back as the same heights, to within half a quantisation step (and f32 rounding).
#[test]
fn real_dem_as_a_16_bit_png_agrees_with_its_gltf() {
    let glb = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/realdata/terrain/jacksboro_fault_dem_257.glb");
    if !glb.exists() {
        eprintln!("skipped: {} is absent", glb.display());
        return;
    }
    let dem = Terrain::load(&glb, &Default::default()).unwrap();
    let n = 257usize;
    let (lo, hi) = (dem.lo, dem.hi);
    let step = [
        (hi.x - lo.x) / (n - 1) as f64,
        (hi.z - lo.z) / (n - 1) as f64,
    ];
    // The glTF's surface at sample (col, row); the outermost samples a hair inside, where a
    // ray straight down still meets the mesh.
    let inside = |v: f64, a: f64, b: f64| v.clamp(a + 1e-3, b - 1e-3);
    let sample = |col: usize, row: usize| {
        let x = inside(lo.x + col as f64 * step[0], lo.x, hi.x);
        let z = inside(lo.z + row as f64 * step[1], lo.z, hi.z);
        dem.height_at(x, z).expect("the DEM covers its bounds")
    };
    let heights: Vec<f64> = (0..n * n).map(|k| sample(k % n, k / n)).collect();
    let (y0, y1) = (lo.y, hi.y);
    let q = (y1 - y0) / 65535.0;
    let values: Vec<u16> = heights
        .iter()
        .map(|h| ((h - y0) / q).round() as u16)
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("dem.png");
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(n as u32, n as u32, values)
        .unwrap()
        .save(&png)
        .unwrap();
    let options = HeightmapOptions {
        size: Some([hi.x - lo.x, hi.z - lo.z]),
        height_range: Some([y0, y1]),
    };
    let map = Terrain::load_with(&png, &options, &Default::default()).unwrap();
    // f32 vertex heights: a few ulps of the largest height.
    let tolerance = 0.5 * q + 4.0 * f32::EPSILON as f64 * y1.abs().max(y0.abs());
    let mut worst: f64 = 0.0;
    for row in 0..n {
        for col in 0..n {
            let x = inside(col as f64 * step[0], 0.0, hi.x - lo.x);
            let z = inside(row as f64 * step[1], 0.0, hi.z - lo.z);
            let h = map.height_at(x, z).unwrap();
            worst = worst.max((h - sample(col, row)).abs());
        }
    }
    eprintln!(
        "real DEM: {n}x{n} over {:.0} x {:.0} m, heights {y0:.1}..{y1:.1} m, quantum {q:.4} m, \
         worst difference {worst:.4} m",
        hi.x - lo.x,
        hi.z - lo.z
    );
    assert!(worst <= tolerance, "{worst} > {tolerance}");
}
