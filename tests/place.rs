//! `texel place` end to end, and the placement's promises: spacing, maximality, habitat,
//! determinism, clear errors.

mod common;

use std::path::{Path, PathBuf};

use common::*;
use texel_forest::formats::instances;
use texel_forest::place::{self, PlaceSettings};
use texel_forest::procedural::builder::{self, MaterialSpec, ModelBuilder};
use texel_forest::species::SpeciesFile;
use texel_forest::terrain::Terrain;

/// A directory holding the fixture species file and, beside it, small texels of the fixture
/// trees where it expects them.
fn forest_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    species_with_texels(dir.path());
    dir
}

fn mountain() -> PathBuf {
    fixture("terrain/mountain.glb")
}

/// Every pair of trees is at least the larger of their two radii apart (as stored, to the
/// centimetre). Checked with a grid of the largest radius, independently of `inspect`.
fn assert_spacing(f: &instances::Forest) {
    let radius = |p: &place::Instance| f.info.species[p.species as usize].radius(p.scale as f64);
    let r_max = f.instances.iter().map(radius).fold(0.0, f64::max);
    let mut cells: std::collections::HashMap<(i64, i64), Vec<usize>> = Default::default();
    let key = |p: &place::Instance| {
        (
            (p.position[0] / r_max).floor() as i64,
            (p.position[2] / r_max).floor() as i64,
        )
    };
    for (i, p) in f.instances.iter().enumerate() {
        cells.entry(key(p)).or_default().push(i);
    }
    for (i, p) in f.instances.iter().enumerate() {
        let (cx, cz) = key(p);
        for dz in -1..=1 {
            for dx in -1..=1 {
                for &j in cells.get(&(cx + dx, cz + dz)).into_iter().flatten() {
                    if j > i {
                        let q = &f.instances[j];
                        let d =
                            (p.position[0] - q.position[0]).hypot(p.position[2] - q.position[2]);
                        assert!(
                            d >= radius(p).max(radius(q)),
                            "trees {i} and {j} are {d} m apart"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn place_writes_a_forest_that_keeps_its_spacing_and_inspect_reads_it() {
    let dir = forest_dir();
    let o = place_on_mountain(dir.path(), &["--depfile", "forest.d"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let f =
        instances::decode(&std::fs::read(dir.path().join("forest.instances")).unwrap()).unwrap();
    assert!(f.instances.len() > 15_000, "{}", f.instances.len());
    for s in 0..4 {
        assert!(
            f.instances.iter().any(|p| p.species == s),
            "species {s} missing"
        );
    }
    assert_spacing(&f);
    // Trees stand on the ground: the terrain's exact height under them, to the centimetre
    // positions are stored to (on slopes up to 60 degrees, half a centimetre across is up to
    // 1.2 cm up).
    let terrain = Terrain::load(&mountain(), &Default::default()).unwrap();
    for p in f.instances.iter().step_by(997) {
        let y = terrain.height_at(p.position[0], p.position[2]).unwrap();
        assert!(
            (p.position[1] - y).abs() <= 0.02,
            "{} vs {y}",
            p.position[1]
        );
    }
    let dep = std::fs::read_to_string(dir.path().join("forest.d")).unwrap();
    for needle in [
        "mountain.glb",
        "species.json",
        "trees/conifer.texel",
        "trees/broadleaf.texel",
        "trees/bare.texel",
    ] {
        assert_eq!(dep.matches(needle).count(), 1, "{needle} once in {dep}");
    }

    let o = run(&["inspect", "forest.instances"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    for field in [
        "trees",
        "per hectare",
        "beech",
        "red pine",
        "spacing",
        "heights",
        "terrain",
    ] {
        assert!(text.contains(field), "{field} missing from\n{text}");
    }
    let o = run(&["inspect", "forest.instances", "--json"], dir.path());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["min_distance_ratio"].as_f64().unwrap() >= 1.0);
    assert!(v["bytes_per_tree"].as_f64().unwrap() < 12.0);
    let o = run(
        &["inspect", "forest.instances", "--map", "-o", "map.png"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).is_empty(),
        "the terrain is found and unchanged: {}",
        stderr(&o)
    );
    let map = image::open(dir.path().join("map.png")).unwrap();
    assert_eq!(map.width(), 1024);
}

#[test]
fn the_same_seed_gives_the_same_bytes_for_any_thread_count() {
    let dir = forest_dir();
    let region = ["--region", "-200,-200,200,150"];
    for (threads, name) in [
        ("1", "a.instances"),
        ("2", "b.instances"),
        ("2", "c.instances"),
    ] {
        let terrain = mountain();
        let mut a = vec![
            "--threads",
            threads,
            "place",
            terrain.to_str().unwrap(),
            "--species",
            "species.json",
            "-o",
            name,
        ];
        a.extend_from_slice(&region);
        let o = run(&a, dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let read = |n: &str| std::fs::read(dir.path().join(n)).unwrap();
    assert_eq!(read("a.instances"), read("b.instances"), "1 thread vs 2");
    assert_eq!(read("b.instances"), read("c.instances"), "twice");
    let o = place_on_mountain(
        dir.path(),
        &["--seed", "2", "--region", "-200,-200,200,150"],
    );
    assert!(o.status.success());
    assert_ne!(
        read("forest.instances"),
        read("a.instances"),
        "another seed, another forest"
    );
}

/// Maximality: wherever the ground suits some species all around, a tree stands within twice
/// the largest radius.
#[test]
fn suitable_ground_has_no_empty_disc_of_twice_the_radius() {
    let terrain = Terrain::load(&mountain(), &Default::default()).unwrap();
    let species = SpeciesFile::load(&fixture("species/forest.json")).unwrap();
    let heights = vec![14.0; species.species.len()];
    let f = place::place(&terrain, &species, &heights, &PlaceSettings::default()).unwrap();
    let r_max = species
        .species
        .iter()
        .map(|s| s.radius(s.height.max))
        .fold(0.0, f64::max);
    let min = species.analysis.min_suitability as f32;
    let suitable = |x: f64, z: f64| {
        f.suitability
            .iter()
            .any(|s| f.raster.interpolate(s, x, z) >= min)
    };
    let mut s = texel_forest::rng::Stream::new(3, 0);
    let (mut checked, mut worst) = (0, 0.0f64);
    for _ in 0..4000 {
        let (x, z) = (
            s.range(-500.0 + 2.0 * r_max, 500.0 - 2.0 * r_max),
            s.range(-500.0 + 2.0 * r_max, 500.0 - 2.0 * r_max),
        );
        let ring = (0..16).all(|k| {
            let a = k as f64 / 16.0 * std::f64::consts::TAU;
            suitable(x + 2.0 * r_max * a.cos(), z + 2.0 * r_max * a.sin())
                && suitable(x + r_max * a.cos(), z + r_max * a.sin())
        });
        if !(ring && suitable(x, z)) {
            continue;
        }
        let nearest = f
            .instances
            .iter()
            .map(|p| (p.position[0] - x).hypot(p.position[2] - z))
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(nearest / r_max);
        checked += 1;
    }
    assert!(checked > 1000, "{checked}");
    println!("largest empty distance: {worst:.3} of the largest radius");
    assert!(worst < 2.0, "{worst}");
}

/// A terrain of parallel ridges and valleys (crests every 400 m) with a shade-tolerant species
/// preferring low topographic position and a sun-loving one preferring high: each dominates
/// its ground, and they mix on the slopes between.
#[test]
fn shade_tolerant_trees_take_the_valleys_and_sun_loving_the_ridges() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = ModelBuilder::default();
    let m = b.material(MaterialSpec {
        name: "ground".into(),
        color: [0.2, 0.3, 0.1, 1.0],
        mask: None,
    });
    let n = 121;
    let heights: Vec<f32> = (0..n * n)
        .map(|k| {
            (40.0 * ((k % n) as f64 * 10.0 / 400.0 * std::f64::consts::TAU).sin() + 100.0) as f32
        })
        .collect();
    b.grid(m, [0.0, 0.0], 10.0, [n, n], &heights);
    let g = b.to_gltf(None, "test");
    let terrain_path = dir.path().join("ridges.glb");
    std::fs::write(&terrain_path, builder::glb(&g.doc, &g.bin)).unwrap();
    let mut file: serde_json::Value =
        serde_json::from_slice(&std::fs::read(fixture("species/forest.json")).unwrap()).unwrap();
    let all = file["species"].as_array().unwrap().clone();
    // Beech (shade-tolerant) and red pine (sun-loving), with broad overlapping preferences.
    let mut beech = all[0].clone();
    beech["habitat"] =
        serde_json::json!({ "topographic_position": { "preferred": -15, "tolerance": 12 } });
    let mut pine = all[1].clone();
    pine["habitat"] =
        serde_json::json!({ "topographic_position": { "preferred": 15, "tolerance": 12 } });
    file["species"] = serde_json::json!([beech, pine]);
    file["analysis"]["tpi_radius"] = serde_json::json!(150);
    let species = SpeciesFile::parse(&serde_json::to_vec(&file).unwrap()).unwrap();
    let terrain = Terrain::load(&terrain_path, &Default::default()).unwrap();
    let f = place::place(&terrain, &species, &[14.0, 14.0], &PlaceSettings::default()).unwrap();
    let tpi = &f.attributes.topographic_position;
    let mean = |s: u8| {
        let v: Vec<f64> = f
            .instances
            .iter()
            .filter(|p| p.species == s)
            .map(|p| f.raster.interpolate(tpi, p.position[0], p.position[2]) as f64)
            .collect();
        (v.iter().sum::<f64>() / v.len() as f64, v.len())
    };
    let ((shade, n_shade), (sun, n_sun)) = (mean(0), mean(1));
    println!(
        "mean topographic position: beech {shade:.1} m ({n_shade} trees), red pine {sun:.1} m ({n_sun} trees)"
    );
    assert!(n_shade > 1000 && n_sun > 1000);
    assert!(shade < -5.0 && sun > 5.0, "beech {shade}, pine {sun}");
    // Mixed stands where habitats overlap: on mid-slope ground both species grow.
    let mid = |p: &&place::Instance| {
        f.raster
            .interpolate(tpi, p.position[0], p.position[2])
            .abs()
            < 3.0
    };
    let on_slopes: Vec<_> = f.instances.iter().filter(mid).collect();
    let beech_share =
        on_slopes.iter().filter(|p| p.species == 0).count() as f64 / on_slopes.len() as f64;
    assert!((0.3..0.7).contains(&beech_share), "{beech_share}");
}

#[test]
fn bad_species_and_terrain_files_give_clear_errors_and_no_output() {
    let dir = forest_dir();
    let base: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("species.json")).unwrap()).unwrap();
    type Edit = Box<dyn Fn(&mut serde_json::Value)>;
    let cases: Vec<(Edit, Vec<&str>)> = vec![
        (
            Box::new(|v| v["species"][0]["heigth"] = serde_json::json!(3)),
            vec!["species[0].heigth", "unknown field"],
        ),
        (
            Box::new(|v| v["species"][1]["texel"] = serde_json::json!("trees/missing.texel")),
            vec!["species[1].texel", "cannot read"],
        ),
        (
            Box::new(|v| v["species"][2]["spacing"] = serde_json::json!(0)),
            vec!["species[2].spacing", "positive"],
        ),
        (
            Box::new(|v| v["species"][3]["spacing"] = serde_json::json!(-1.5)),
            vec!["species[3].spacing"],
        ),
        (
            Box::new(|v| v["species"][0]["seasons"]["foliage"] = serde_json::json!([])),
            vec!["species[0].seasons.foliage", "empty"],
        ),
        (
            Box::new(|v| v["species"][0]["leafless_texel"] = serde_json::json!("species.json")),
            vec!["species[0].leafless_texel", "not a texel file"],
        ),
        // Valid one by one, but radii placement cannot mix.
        (
            Box::new(|v| v["species"][2]["spacing"] = serde_json::json!(0.01)),
            vec!["tree radii range", "spacing"],
        ),
        // Heights no forest can store as scales of the model.
        (
            Box::new(|v| {
                v["species"][1]["height"] = serde_json::json!({ "min": 1e300, "max": 1e300 })
            }),
            vec!["bad.json: species[1].height", "1e300", "2^16"],
        ),
    ];
    for (edit, needles) in cases {
        let mut v = base.clone();
        edit(&mut v);
        std::fs::write(dir.path().join("bad.json"), serde_json::to_vec(&v).unwrap()).unwrap();
        let terrain = mountain();
        let o = run(
            &[
                "place",
                terrain.to_str().unwrap(),
                "--species",
                "bad.json",
                "-o",
                "bad.instances",
            ],
            dir.path(),
        );
        let mut all = vec!["bad.json"];
        all.extend(needles);
        assert_error(&o, &all);
        assert!(!dir.path().join("bad.instances").exists());
    }
    let o = place_on_mountain(dir.path(), &["--region", "5000,5000,6000,6000"]);
    assert_error(&o, &["--region", "outside the terrain"]);
    // A malformed value is a usage error, caught before anything is read.
    let o = place_on_mountain(dir.path(), &["--region", "1,2,3"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--region") && stderr(&o).contains("four numbers"));
    // A terrain without triangles.
    let points = serde_json::json!({
        "asset": { "version": "2.0" },
        "scenes": [{ "nodes": [0] }], "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 }, "mode": 0 }] }],
        "accessors": [{ "bufferView": 0, "componentType": 5126, "count": 1, "type": "VEC3" }],
        "bufferViews": [{ "buffer": 0, "byteLength": 12 }],
        "buffers": [{ "byteLength": 12, "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAA" }]
    });
    std::fs::write(
        dir.path().join("flat.gltf"),
        serde_json::to_vec(&points).unwrap(),
    )
    .unwrap();
    let o = run(
        &[
            "place",
            "flat.gltf",
            "--species",
            "species.json",
            "-o",
            "x.instances",
        ],
        dir.path(),
    );
    assert_error(&o, &["flat.gltf", "no triangles"]);
    // Terrains of one triangle that place and inspect must refuse, naming the file. A wall,
    // standing in the x-y plane: no ground seen from above (it was reported as a zero --cell,
    // a flag never given). A spike 3e38 m high: valid f32, but rays cast down on it
    // overflowed, and the whole terrain read as "0 of 64 cells have terrain".
    let wall = [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0]];
    let spike = [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 3e38, 10.0]];
    for (name, corners, expected) in [
        ("wall.gltf", wall, &["no ground seen from above"][..]),
        (
            "spike.gltf",
            spike,
            &["reaches 3e38 m", "a vertex at (0, 3e38, 10) m"][..],
        ),
    ] {
        write_triangle_terrain(&dir.path().join(name), corners);
        for args in [
            &[
                "place",
                name,
                "--species",
                "species.json",
                "-o",
                "x.instances",
            ][..],
            &["inspect", name][..],
        ] {
            let o = run(args, dir.path());
            assert_error(&o, &[&[name][..], expected].concat());
            assert!(!stderr(&o).contains("--cell"), "{}", stderr(&o));
        }
    }
    assert!(
        !dir.path().join("forest.instances").exists() && !dir.path().join("x.instances").exists()
    );
}

/// A glTF terrain of one triangle with these corners, its buffer in a data URI.
fn write_triangle_terrain(path: &Path, corners: [[f32; 3]; 3]) {
    use base64::Engine as _;
    let bytes: Vec<u8> = corners
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let (lo, hi) = (0..3)
        .map(|a| {
            let v = corners.map(|c| c[a]);
            (
                v.into_iter().fold(f32::INFINITY, f32::min),
                v.into_iter().fold(f32::NEG_INFINITY, f32::max),
            )
        })
        .unzip::<_, _, Vec<f32>, Vec<f32>>();
    let doc = serde_json::json!({
        "asset": { "version": "2.0" },
        "scenes": [{ "nodes": [0] }], "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 } }] }],
        "accessors": [{ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                        "min": lo, "max": hi }],
        "bufferViews": [{ "buffer": 0, "byteLength": 36 }],
        "buffers": [{ "byteLength": 36, "uri": format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&bytes)
        ) }]
    });
    std::fs::write(path, serde_json::to_vec(&doc).unwrap()).unwrap();
}

#[test]
fn the_real_terrain_takes_a_forest() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/realdata/terrain/jacksboro_fault_dem_257.glb");
    if !path.exists() {
        eprintln!("skipped: {} is absent", path.display());
        return;
    }
    let dir = forest_dir();
    // A 3 km square in the middle of the 30 km DEM (149 m x 185 m cells).
    let o = run(
        &[
            "place",
            path.to_str().unwrap(),
            "--species",
            "species.json",
            "-o",
            "real.instances",
            "--region",
            "13000,14000,16000,17000",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let f = instances::decode(&std::fs::read(dir.path().join("real.instances")).unwrap()).unwrap();
    assert!(f.instances.len() > 10_000, "{}", f.instances.len());
    assert!(
        f.instances
            .iter()
            .all(|p| (245.0..=1068.0).contains(&p.position[1]))
    );
    assert_spacing(&f);
}

/// A copy of the fixture species file with `edit` applied to every species.
fn species_variant(dir: &Path, name: &str, mut edit: impl FnMut(&mut serde_json::Value)) {
    let mut v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("species.json")).unwrap()).unwrap();
    for s in v["species"].as_array_mut().unwrap() {
        edit(s);
    }
    std::fs::write(dir.join(name), v.to_string()).unwrap();
}

#[test]
fn an_empty_forest_says_why_and_inspect_says_no_trees() {
    let dir = forest_dir();
    // Cliffs only: nothing on the mountain is that steep.
    species_variant(dir.path(), "cliffs.json", |s| {
        s["habitat"] = serde_json::json!({ "slope": { "min": 85, "max": 90 } })
    });
    let t = mountain();
    let o = run(
        &[
            "place",
            t.to_str().unwrap(),
            "--species",
            "cliffs.json",
            "-o",
            "empty.instances",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    for needle in [
        "the forest is empty",
        "raster        7.81 m cells",
        "slope",
        "95%",
        "suits 0.0% of the ground; asks for slope 85..90",
    ] {
        assert!(err.contains(needle), "{needle:?} not in {err}");
    }
    let o = run(&["inspect", "empty.instances"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(
        text.contains("no trees") && text.contains("fewer than two trees"),
        "{text}"
    );
    assert!(!text.contains("inf"), "{text}");
    let o = run(&["inspect", "empty.instances", "--json"], dir.path());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(
        v["bytes_per_tree"].is_null() && v["min_distance"].is_null(),
        "{v}"
    );
}

/// One species taking every tree is worth a warning that names it and what the others ask
/// for; `place`'s summary line says "no trees" rather than bytes per tree for an empty forest,
/// and shows names from the species file escaped.
#[test]
fn a_one_sided_forest_says_why_and_names_are_escaped() {
    let dir = forest_dir();
    // Every species but the first asks for cliffs; the first is renamed with a terminal escape.
    let mut first = true;
    species_variant(dir.path(), "one.json", |s| {
        if first {
            s["name"] = serde_json::json!("beech\u{1b}[2J");
            first = false;
        } else {
            s["habitat"] = serde_json::json!({ "slope": { "min": 85, "max": 90 } });
        }
    });
    let t = mountain();
    let o = run(
        &[
            "place",
            t.to_str().unwrap(),
            "--species",
            "one.json",
            "-o",
            "one.instances",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains(
            "every tree is \"beech\\u{1b}[2J\": no ground in the region suits the other species"
        ),
        "{err}"
    );
    assert!(err.contains("asks for slope 85..90"), "{err}");
    assert!(
        !err.contains('\u{1b}'),
        "an escape reached the terminal: {err:?}"
    );

    species_variant(dir.path(), "cliffs.json", |s| {
        s["habitat"] = serde_json::json!({ "slope": { "min": 85, "max": 90 } })
    });
    let o = run(
        &[
            "place",
            t.to_str().unwrap(),
            "--species",
            "cliffs.json",
            "-o",
            "empty.instances",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("placed 0 trees") && err.contains("no trees"),
        "{err}"
    );
    assert!(!err.contains("bytes per tree"), "{err}");
}

#[test]
fn nothing_grows_below_the_sea_or_outside_a_species_elevation_band() {
    let dir = forest_dir();
    let t = mountain();
    let o = place_on_mountain(dir.path(), &["--sea-level", "300"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let f =
        instances::decode(&std::fs::read(dir.path().join("forest.instances")).unwrap()).unwrap();
    assert!(f.instances.len() > 1000);
    let lowest = f
        .instances
        .iter()
        .map(|p| p.position[1])
        .fold(f64::INFINITY, f64::min);
    assert!(lowest >= 300.0 - 0.005, "a tree stands at {lowest} m");
    // A sea above every summit empties the forest, and the warning blames the flag.
    let o = place_on_mountain(dir.path(), &["--sea-level", "1e9"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("--sea-level 1000000000 m lies above all the ground"),
        "{err}"
    );

    // An elevation band holds at each tree's exact ground, not only on the raster.
    species_variant(dir.path(), "high.json", |s| {
        s["habitat"]["elevation"] = serde_json::json!({ "min": 350, "max": 10000 })
    });
    let o = run(
        &[
            "place",
            t.to_str().unwrap(),
            "--species",
            "high.json",
            "-o",
            "high.instances",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let f = instances::decode(&std::fs::read(dir.path().join("high.instances")).unwrap()).unwrap();
    assert!(!f.instances.is_empty());
    assert!(f.instances.iter().all(|p| p.position[1] >= 350.0 - 0.005));
}

#[test]
fn inspect_of_a_terrain_shows_what_a_species_file_needs() {
    let dir = forest_dir();
    let t = mountain();
    let t = t.to_str().unwrap();
    let o = run(&["inspect", t], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    for needle in [
        "32768 triangles",
        "7.81 m cells",
        "elevation",
        "slope",
        "aspect",
        "topographic_position",
        "wetness",
        "50%",
        "sha256",
    ] {
        assert!(text.contains(needle), "{needle:?} not in {text}");
    }
    let o = run(
        &[
            "inspect",
            t,
            "--species",
            "species.json",
            "--json",
            "--cell",
            "20",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["survey"]["cell"], 20.0);
    let fits = v["survey"]["species"].as_array().unwrap();
    assert_eq!(fits.len(), 4);
    assert!(
        fits.iter()
            .all(|f| f["suitable_share"].as_f64().unwrap() > 0.0),
        "{v}"
    );
    // Elevation percentiles bracket the fixture mountain's heights.
    let elevation = &v["survey"]["attributes"][0];
    assert!(
        elevation["min"].as_f64().unwrap() >= 169.0 && elevation["max"].as_f64().unwrap() <= 468.0
    );
    let o = run(&["inspect", t, "--map", "-o", "attributes.png"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let img = image::open(dir.path().join("attributes.png")).unwrap();
    assert!(img.width() > 3 * 128 && img.height() > 2 * 128);
}
