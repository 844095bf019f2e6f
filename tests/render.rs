//! `texel render` end to end: an EXR that OpenEXR readers take, a preview, crops that match,
//! and refusal of missing or stale inputs before any rendering.

mod common;

use std::path::Path;

use common::*;

/// A small forest: the fixture trees baked coarse, placed on part of the fixture mountain.
fn small_forest() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    species_with_texels(dir.path());
    let o = place_on_mountain(dir.path(), &["--region=-120,-120,120,120"]);
    assert!(o.status.success(), "{}", stderr(&o));
    dir
}

const VIEW: [&str; 8] = [
    "--eye=-150,450,260",
    "--target",
    "0,300,0",
    "--width",
    "64",
    "--height",
    "36",
    "--fov",
];

fn render(dir: &Path, extra: &[&str]) -> std::process::Output {
    let mut a = vec!["render", "forest.instances"];
    a.extend_from_slice(&VIEW);
    a.push("40");
    a.extend_from_slice(extra);
    run(&a, dir)
}

#[test]
fn renders_an_exr_that_openexr_reads_with_depth_aovs_and_camera_matrices() {
    let dir = small_forest();
    let o = render(
        dir.path(),
        &[
            "-o",
            "frame.exr",
            "--preview",
            "frame.png",
            "--aov",
            "normal,albedo,canopy,species",
            "--depfile",
            "frame.d",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let image = exr::prelude::read_all_flat_layers_from_file(dir.path().join("frame.exr")).unwrap();
    let layer = &image.layer_data[0];
    let names: Vec<String> = layer
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    for want in [
        "R",
        "G",
        "B",
        "A",
        "Z",
        "normal.X",
        "albedo.G",
        "canopy.A",
        "species.id",
    ] {
        assert!(
            names.iter().any(|n| n == want),
            "{want} missing from {names:?}"
        );
    }
    assert_eq!(layer.size, exr::prelude::Vec2(64, 36));
    assert!(
        layer.attributes.world_to_camera.is_some()
            && layer.attributes.world_to_normalized_device.is_some()
    );
    // Premultiplied, finite, alpha in [0, 1]; the forest covers part of the frame.
    let channel = |name: &str| {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .unwrap()
            .sample_data
            .values_as_f32()
            .collect::<Vec<f32>>()
    };
    let (r, a) = (channel("R"), channel("A"));
    assert!(r.iter().chain(&a).all(|v| v.is_finite()));
    assert!(a.iter().all(|v| (0.0..=1.0).contains(v)));
    assert!(
        a.iter().filter(|&&v| v > 0.5).count() > 100,
        "the terrain and trees fill the view"
    );
    assert!(
        r.iter().zip(&a).all(|(r, a)| *r <= a * 1.5 + 1e-6),
        "premultiplied by alpha"
    );
    let preview = image::open(dir.path().join("frame.png")).unwrap();
    assert_eq!((preview.width(), preview.height()), (64, 36));
    let dep = std::fs::read_to_string(dir.path().join("frame.d")).unwrap();
    for needle in [
        "forest.instances",
        "mountain.glb",
        "trees/conifer.texel",
        "trees/broadleaf.texel",
    ] {
        assert!(dep.contains(needle), "{needle} missing from {dep}");
    }
}

#[test]
fn a_crop_equals_its_region_of_the_full_frame_and_threads_do_not_matter() {
    let dir = small_forest();
    assert!(
        render(dir.path(), &["-o", "full.exr", "--threads", "1", "--half"])
            .status
            .success()
    );
    assert!(
        render(dir.path(), &["-o", "full2.exr", "--threads", "2", "--half"])
            .status
            .success()
    );
    let o = render(
        dir.path(),
        &["-o", "crop.exr", "--crop", "10,5,40,30", "--half"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let read = |n: &str| std::fs::read(dir.path().join(n)).unwrap();
    assert_eq!(read("full.exr"), read("full2.exr"));
    let full = exr::prelude::read_all_flat_layers_from_file(dir.path().join("full.exr")).unwrap();
    let crop = exr::prelude::read_all_flat_layers_from_file(dir.path().join("crop.exr")).unwrap();
    let (f, c) = (&full.layer_data[0], &crop.layer_data[0]);
    assert_eq!(c.size, exr::prelude::Vec2(30, 25));
    assert_eq!(c.attributes.layer_position, exr::prelude::Vec2(10, 5));
    for name in ["R", "A", "Z"] {
        let values = |l: &exr::image::Layer<exr::image::AnyChannels<exr::image::FlatSamples>>| {
            l.channel_data
                .list
                .iter()
                .find(|ch| ch.name.to_string() == name)
                .unwrap()
                .sample_data
                .values_as_f32()
                .collect::<Vec<f32>>()
        };
        let (fv, cv) = (values(f), values(c));
        for y in 0..25 {
            for x in 0..30 {
                assert_eq!(
                    cv[x + 30 * y].to_bits(),
                    fv[(x + 10) + 64 * (y + 5)].to_bits(),
                    "{name} at {x},{y}"
                );
            }
        }
    }
}

#[test]
fn missing_or_stale_inputs_are_refused_before_rendering() {
    let dir = small_forest();
    for (flags, needle) in [
        (vec!["--crop", "0,0,2000,10"], "--crop"),
        (vec!["--spp", "0"], "--spp"),
        (vec!["--sun", "10"], "--sun"),
        (vec!["--day", "400"], "--day"),
        (vec!["--camera", "nope"], "no such camera"),
    ] {
        let mut a = vec!["render", "forest.instances", "-o", "x.exr"];
        a.extend(flags);
        assert_error(&run(&a, dir.path()), &[needle]);
    }
    // A texel rebaked since placement.
    let o = run(
        &[
            "bake",
            fixture("trees/conifer.glb").to_str().unwrap(),
            "-o",
            "trees/conifer.texel",
            "--resolution",
            "4",
            "--fine",
            "16",
        ],
        dir.path(),
    );
    assert!(o.status.success());
    let o = render(dir.path(), &["-o", "stale.exr"]);
    assert_error(
        &o,
        &[
            "forest.instances",
            "trees/conifer.texel",
            "changed since the forest was placed",
        ],
    );
    std::fs::remove_file(dir.path().join("trees/conifer.texel")).unwrap();
    let o = render(dir.path(), &["-o", "missing.exr"]);
    assert_error(
        &o,
        &["forest.instances", "cannot read", "trees/conifer.texel"],
    );
    assert!(
        !dir.path().join("stale.exr").exists()
            && !dir.path().join("missing.exr").exists()
            && !dir.path().join("x.exr").exists()
    );
}
