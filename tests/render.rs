//! `texel render` end to end: an EXR that OpenEXR readers take, a preview, crops that match,
//! and refusal of missing or stale inputs before any rendering.

mod common;

use std::path::Path;

use common::*;

/// A small forest: the fixture trees baked coarse, placed on part of the fixture mountain.
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
        "N.X",
        "albedo.G",
        "canopy.A",
        "species.X",
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
    // OpenEXR's own reader takes it too, where its tools are installed (`.ci/run` installs
    // them; elsewhere this part is skipped).
    match std::process::Command::new("exrheader")
        .arg(dir.path().join("frame.exr"))
        .output()
    {
        Ok(o) => {
            let text = String::from_utf8_lossy(&o.stdout);
            assert!(o.status.success(), "exrheader: {}", stderr(&o));
            for needle in ["worldToCamera", "worldToNDC", "N.X", "species.X"] {
                assert!(text.contains(needle), "{needle} missing from {text}");
            }
        }
        Err(_) => eprintln!("exrheader not installed: OpenEXR's own reader not tried"),
    }
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
    // The hybrid method with a switch and band that draw this view's trees both ways.
    let hybrid = ["--method", "hybrid", "--lod-switch", "2", "--lod-band", "2"];
    // Shadow rays from the cached depths, whose grids are built by whichever thread needs
    // them first.
    let cached = ["--shadows", "cached"];
    // Pixels at edges rendered again: a crop's border compares with pixels outside it.
    let edges = [
        "--method",
        "hybrid",
        "--lod-switch",
        "2",
        "--lod-band",
        "2",
        "--edge-spp",
        "4",
    ];
    for method in [&[][..], &hybrid[..], &cached[..], &edges[..]] {
        let run = |extra: &[&str]| {
            let mut a = extra.to_vec();
            a.extend_from_slice(&["--half", "--aov", "lod,canopy"]);
            a.extend_from_slice(method);
            let o = render(dir.path(), &a);
            assert!(o.status.success(), "{}", stderr(&o));
        };
        run(&["-o", "full.exr", "--threads", "1"]);
        run(&["-o", "full2.exr", "--threads", "2"]);
        run(&["-o", "crop.exr", "--crop", "10,5,40,30"]);
        let read = |n: &str| std::fs::read(dir.path().join(n)).unwrap();
        assert_eq!(read("full.exr"), read("full2.exr"), "{method:?}");
        let full =
            exr::prelude::read_all_flat_layers_from_file(dir.path().join("full.exr")).unwrap();
        let crop =
            exr::prelude::read_all_flat_layers_from_file(dir.path().join("crop.exr")).unwrap();
        let (f, c) = (&full.layer_data[0], &crop.layer_data[0]);
        assert_eq!(c.size, exr::prelude::Vec2(30, 25));
        assert_eq!(c.attributes.layer_position, exr::prelude::Vec2(10, 5));
        let values = |l: &exr::image::Layer<exr::image::AnyChannels<exr::image::FlatSamples>>,
                      name: &str| {
            l.channel_data
                .list
                .iter()
                .find(|ch| ch.name.to_string() == name)
                .unwrap()
                .sample_data
                .values_as_f32()
                .collect::<Vec<f32>>()
        };
        for name in ["R", "A", "Z", "lod_mesh.A"] {
            let (fv, cv) = (values(f, name), values(c, name));
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
        // The representation layers split the canopy between them; the texel method draws no
        // tree as a model, the hybrid here draws some each way.
        let sum = |name: &str| values(f, name).iter().map(|&v| f64::from(v)).sum::<f64>();
        let (mesh, texel, canopy) = (sum("lod_mesh.A"), sum("lod_texel.A"), sum("canopy.A"));
        assert!(
            (mesh + texel - canopy).abs() < 0.01 * canopy + 0.1,
            "{mesh} + {texel} against {canopy}"
        );
        if !method.contains(&"hybrid") {
            // The default draws this view's trees from their textures, but for the outline's
            // pixels, whose four samples' finer footprints draw a few of them from models.
            assert!(mesh < 0.05 * canopy, "models {mesh} of {canopy}");
        } else {
            assert!(
                mesh > 0.1 * canopy && texel > 0.1 * canopy,
                "models {mesh}, textures {texel} of {canopy}"
            );
        }
    }
}

/// The R, G, B, A values of an EXR and its worldToCamera matrix.
fn rgba_and_view(path: &Path) -> (Vec<f32>, [f32; 16]) {
    let image = exr::prelude::read_all_flat_layers_from_file(path).unwrap();
    let layer = &image.layer_data[0];
    let channel = |name: &str| -> Vec<f32> {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .unwrap()
            .sample_data
            .values_as_f32()
            .collect()
    };
    let values = ["R", "G", "B", "A"]
        .iter()
        .flat_map(|c| channel(c))
        .collect();
    (values, layer.attributes.world_to_camera.unwrap())
}

#[test]
fn a_gltf_camera_node_and_directional_light_stand_in_for_the_flags() {
    let dir = small_forest();
    // The view of VIEW with a 40 degree field, and the sun at azimuth 120, elevation 35, as a
    // glTF camera node and KHR_lights_punctual light (a file with no mesh at all).
    let (eye, target) = (
        glam::Vec3::new(-150.0, 450.0, 260.0),
        glam::Vec3::new(0.0, 300.0, 0.0),
    );
    // A glTF camera looks down its -Z with +Y up.
    let forward = (target - eye).normalize();
    let right = forward.cross(glam::Vec3::Y).normalize();
    let look = glam::Quat::from_mat3(&glam::Mat3::from_cols(
        right,
        right.cross(forward),
        -forward,
    ));
    let (az, el) = (120f32.to_radians(), 35f32.to_radians());
    let towards = glam::Vec3::new(az.sin() * el.cos(), el.sin(), -az.cos() * el.cos());
    let sun = glam::Quat::from_rotation_arc(glam::Vec3::Z, towards);
    let doc = serde_json::json!({
        "asset": { "version": "2.0" },
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": { "KHR_lights_punctual": { "lights": [{ "type": "directional" }] } },
        "scenes": [{ "nodes": [0, 1, 2] }],
        "nodes": [
            { "name": "lookout", "camera": 0, "translation": eye.to_array(),
              "rotation": look.to_array() },
            { "extensions": { "KHR_lights_punctual": { "light": 0 } }, "rotation": sun.to_array() },
            { "camera": 1 },
        ],
        "cameras": [
            { "type": "perspective", "name": "overlook",
              "perspective": { "yfov": 40f32.to_radians(), "znear": 0.1 } },
            { "type": "orthographic", "name": "plan",
              "orthographic": { "xmag": 500.0, "ymag": 500.0, "znear": 0.1, "zfar": 1e4 } },
        ],
    });
    std::fs::write(dir.path().join("view.gltf"), doc.to_string()).unwrap();
    let o = run(
        &[
            "render",
            "forest.instances",
            "--camera-file",
            "view.gltf",
            "--camera",
            "overlook",
            "--width",
            "64",
            "--height",
            "36",
            "-o",
            "gltf.exr",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // The camera's node names it as well as the camera's own name does.
    let mut by_node = vec!["render", "forest.instances", "--camera-file", "view.gltf"];
    by_node.extend(["--camera", "lookout", "--width", "64", "--height", "36"]);
    by_node.extend(["-o", "node.exr"]);
    let o = run(&by_node, dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    assert_same_bytes(dir.path(), "gltf.exr", "node.exr");
    // An orthographic camera is there, but not drawable: said so, not "no such camera".
    let plan = ["render", "forest.instances", "--camera-file", "view.gltf"];
    let o = run(
        &[&plan[..], &["--camera", "plan", "-o", "plan.exr"]].concat(),
        dir.path(),
    );
    assert_error(&o, &["--camera \"plan\" is an orthographic camera"]);
    let o = render(dir.path(), &["--sun", "120,35", "-o", "flags.exr"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (a, va) = rgba_and_view(&dir.path().join("gltf.exr"));
    let (b, vb) = rgba_and_view(&dir.path().join("flags.exr"));
    for (x, y) in va.iter().zip(&vb) {
        assert!((x - y).abs() < 1e-3 * (1.0 + y.abs()), "{va:?} vs {vb:?}");
    }
    // The same view and light, up to rounding in how the rays are made.
    let mean = b.iter().map(|v| v.abs()).sum::<f32>() / b.len() as f32;
    let diff = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).sum::<f32>() / b.len() as f32;
    assert!(
        diff < 0.01 * mean,
        "mean difference {diff} against mean value {mean}"
    );
    // A different sun is visibly different: the test can tell.
    let o = render(dir.path(), &["--sun", "300,35", "-o", "other.exr"]);
    assert!(o.status.success());
    let (c, _) = rgba_and_view(&dir.path().join("other.exr"));
    let other = c.iter().zip(&b).map(|(x, y)| (x - y).abs()).sum::<f32>() / b.len() as f32;
    assert!(other > 10.0 * diff.max(1e-4 * mean), "{other} vs {diff}");
}

#[test]
fn the_mesh_method_draws_the_models_the_texels_were_baked_from_and_refuses_stale_ones_the_default_falls_back_to_textures()
 {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The trees baked from copies of the fixtures, so that a model can be changed afterwards.
    std::fs::create_dir_all(d.join("models")).unwrap();
    for f in [
        "conifer.glb",
        "broadleaf.gltf",
        "broadleaf.bin",
        "broadleaf_0.png",
        "bare.glb",
    ] {
        std::fs::copy(fixture(&format!("trees/{f}")), d.join("models").join(f)).unwrap();
    }
    std::fs::copy(fixture("species/forest.json"), d.join("species.json")).unwrap();
    for name in ["conifer.glb", "broadleaf.gltf", "bare.glb"] {
        let stem = name.split('.').next().unwrap();
        let o = bake_coarse(d, &format!("models/{name}"), &format!("trees/{stem}.texel"));
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let o = place_on_mountain(d, &["--region=-120,-120,120,120"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = render(
        d,
        &[
            "--method",
            "mesh",
            "--spp",
            "4",
            "-o",
            "mesh.exr",
            "--depfile",
            "mesh.d",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("from their meshes"), "{}", stderr(&o));
    let (values, _) = rgba_and_view(&d.join("mesh.exr"));
    let alpha = &values[3 * values.len() / 4..];
    assert!(values.iter().all(|v| v.is_finite()));
    assert!(alpha.iter().filter(|&&a| a > 0.5).count() > 100);
    let dep = std::fs::read_to_string(d.join("mesh.d")).unwrap();
    for needle in [
        "models/conifer.glb",
        "models/broadleaf.bin",
        "models/broadleaf_0.png",
    ] {
        assert!(dep.contains(needle), "{needle} missing from {dep}");
    }
    // A model changed since its bake: refused, naming the texel and the model.
    let mut bytes = std::fs::read(d.join("models/broadleaf.bin")).unwrap();
    bytes[0] ^= 1;
    std::fs::write(d.join("models/broadleaf.bin"), bytes).unwrap();
    let o = render(d, &["--method", "mesh", "-o", "stale.exr"]);
    assert_error(
        &o,
        &[
            "trees/broadleaf.texel",
            "models/broadleaf.bin",
            "changed since it was baked",
        ],
    );
    assert!(!d.join("stale.exr").exists());
    let o = render(d, &["--method", "hybrid", "-o", "stale.exr"]);
    assert_error(&o, &["models/broadleaf.bin", "changed since it was baked"]);
    assert!(!d.join("stale.exr").exists());
    // The texel method does not need the models; the default (hybrid, while the models were
    // good) draws the textures instead, and says why.
    let o = render(d, &["--method", "texel", "-o", "texel.exr"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = render(d, &["-o", "default.exr", "--depfile", "default.d"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    for needle in [
        "warning",
        "every tree drawn from its texture",
        "models/broadleaf.bin",
        "changed since it was baked",
        "from their textures",
    ] {
        assert!(err.contains(needle), "{needle} missing from {err}");
    }
    assert_same_bytes(d, "default.exr", "texel.exr");
    // No model is a dependency of a render that drew none.
    let dep = std::fs::read_to_string(d.join("default.d")).unwrap();
    assert!(!dep.contains("models/"), "{dep}");
    // The forest and its textures copied without the models, as to another machine.
    std::fs::remove_dir_all(d.join("models")).unwrap();
    let o = render(d, &["-o", "moved.exr"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("every tree drawn from its texture"), "{err}");
    assert!(
        err.contains("cannot read trees/../models/broadleaf.gltf")
            && err.contains("put it back where it was recorded, or re-run texel bake"),
        "{err}"
    );
    assert_same_bytes(d, "moved.exr", "texel.exr");
}

/// Two renders in `dir` wrote the same bytes.
fn assert_same_bytes(dir: &Path, a: &str, b: &str) {
    let read = |f: &str| std::fs::read(dir.join(f)).unwrap();
    assert!(read(a) == read(b), "{a} and {b} differ");
}

/// `texel render forest.instances -o out` in `dir`, 128 x 72 pixels at a 40-degree field of
/// view from `eye` (the whole flag) towards `target`, with `extra`.
fn render_128x72(
    dir: &Path,
    (eye, target): (&str, &str),
    out: &str,
    extra: &[&str],
) -> std::process::Output {
    let mut a = vec![
        "render",
        "forest.instances",
        "-o",
        out,
        eye,
        "--target",
        target,
        "--fov",
        "40",
        "--width",
        "128",
        "--height",
        "72",
    ];
    a.extend_from_slice(extra);
    run(&a, dir)
}

/// The colour's and alpha's RMSE of `image` against `reference`, both in `dir`
/// (`texel compare --json`).
fn rmse_against(dir: &Path, image: &str, reference: &str) -> [f64; 2] {
    let o = run(&["compare", image, reference, "--json"], dir);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let all = &json["all"];
    ["rgb", "alpha"].map(|c| all[c]["rmse"].as_f64().unwrap())
}

/// Every method's samples go through their strata's centres unless `--jitter` asks for random
/// points: at 1 spp on the small forest (128 x 72) the centred image lies nearer an unbiased
/// (jittered) 64-spp mesh render than jittered images of three seeds, for the texel method by
/// more than a tenth (measured: texel 0.0101 against 0.0136-0.0138, mesh 0.0205 against
/// 0.0223-0.0228, hybrid 0.0168 against 0.0189-0.0192).
#[test]
fn centred_samples_land_nearer_the_reference_than_jittered_ones_for_every_method() {
    let dir = small_forest();
    let d = dir.path();
    let render = |out: &str, extra: &[&str]| {
        let mut a = vec!["-q"];
        a.extend_from_slice(extra);
        let o = render_128x72(d, ("--eye=-150,450,260", "0,300,0"), out, &a);
        assert!(o.status.success(), "{}", stderr(&o));
    };
    render(
        "reference.exr",
        &["--method", "mesh", "--spp", "64", "--jitter", "--seed", "9"],
    );
    let error = |image: &str| rmse_against(d, image, "reference.exr")[0];
    for (method, margin) in [("texel", 0.9), ("mesh", 1.0), ("hybrid", 1.0)] {
        render("centred.exr", &["--method", method]);
        let centred = error("centred.exr");
        for seed in ["1", "2", "3"] {
            render(
                "jittered.exr",
                &["--method", method, "--jitter", "--seed", seed],
            );
            let jittered = error("jittered.exr");
            assert!(
                centred < margin * jittered,
                "{method}: centred {centred} against jittered {jittered} (seed {seed})"
            );
        }
    }
}

/// A hybrid frame whose every tree is a texture (here, a switch at a hundredth of a cell)
/// reads no model: it says so, and its image is the texel method's.
#[test]
fn a_hybrid_frame_that_draws_no_model_says_so_and_is_the_texel_methods_image() {
    let dir = small_forest();
    let d = dir.path();
    let o = render(
        d,
        &[
            "--method",
            "hybrid",
            "--lod-switch",
            "0.01",
            "-o",
            "far.exr",
        ],
    );
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("from their textures (hybrid: none near enough"),
        "{err}"
    );
    let o = render(d, &["--method", "texel", "-o", "texel.exr"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_same_bytes(d, "far.exr", "texel.exr");
}

#[test]
fn the_default_method_is_the_hybrid_where_the_models_are_there() {
    let dir = small_forest();
    let d = dir.path();
    let o = render(d, &["-o", "default.exr"]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("from their meshes and textures") || err.contains("(hybrid: none near"),
        "{err}"
    );
    assert!(!err.contains("warning"), "{err}");
    let o = render(d, &["--method", "hybrid", "-o", "hybrid.exr"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_same_bytes(d, "default.exr", "hybrid.exr");
}

#[test]
fn missing_or_stale_inputs_are_refused_before_rendering() {
    let dir = small_forest();
    for (flags, needle) in [
        (vec!["--crop", "0,0,2000,10"], "--crop"),
        (
            vec!["--camera", "nope"],
            "no perspective camera or camera node",
        ),
    ] {
        let mut a = vec!["render", "forest.instances", "-o", "x.exr"];
        a.extend(flags);
        assert_error(&run(&a, dir.path()), &[needle]);
    }
    // A value no run could use is a usage error (status 2), found before anything is read.
    for (flags, needle) in [
        (vec!["--spp", "0"], "--spp"),
        (vec!["--sun", "10"], "--sun"),
        (vec!["--day", "400"], "--day"),
    ] {
        let mut a = vec!["render", "forest.instances", "-o", "x.exr"];
        a.extend(&flags);
        let o = run(&a, dir.path());
        assert_eq!(o.status.code(), Some(2), "{flags:?}");
        assert!(stderr(&o).contains(needle), "{}", stderr(&o));
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

#[test]
fn the_default_camera_frames_the_forest_not_the_whole_terrain() {
    // The forest covers 240 m of the 1 km mountain.
    let dir = small_forest();
    let o = run(
        &[
            "render",
            "forest.instances",
            "-o",
            "f.exr",
            "--width",
            "64",
            "--height",
            "36",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let image = exr::prelude::read_all_flat_layers_from_file(dir.path().join("f.exr")).unwrap();
    let m = image.layer_data[0]
        .attributes
        .world_to_normalized_device
        .unwrap();
    let ndc = |x: f64, y: f64, z: f64| {
        let v = [x, y, z, 1.0];
        let c: [f64; 4] = std::array::from_fn(|j| (0..4).map(|i| v[i] * m[4 * i + j] as f64).sum());
        (c[0] / c[3], c[1] / c[3])
    };
    let corners: Vec<(f64, f64)> = [
        (-120.0, -120.0),
        (120.0, -120.0),
        (-120.0, 120.0),
        (120.0, 120.0),
    ]
    .iter()
    .map(|&(x, z)| ndc(x, 380.0, z))
    .collect();
    let (x0, x1) = corners
        .iter()
        .fold((f64::MAX, f64::MIN), |a, c| (a.0.min(c.0), a.1.max(c.0)));
    assert!(
        x0 > -0.05 && x1 < 1.05,
        "the region is in the frame: {corners:?}"
    );
    assert!(
        x1 - x0 > 0.5,
        "and fills much of it, not a speck: {corners:?}"
    );
}

#[test]
fn an_eye_under_the_terrain_is_worth_a_warning() {
    let dir = small_forest();
    let o = render_at(dir.path(), "--eye=0,100,0", "50,100,0");
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("texel: warning:") && err.contains("below the terrain"),
        "{err}"
    );
    let o = render_at(dir.path(), "--eye=0,900,0", "50,400,0");
    assert!(!stderr(&o).contains("below the terrain"), "{}", stderr(&o));
}

fn render_at(dir: &Path, eye: &str, target: &str) -> std::process::Output {
    run(
        &[
            "render",
            "forest.instances",
            "-o",
            "e.exr",
            eye,
            "--target",
            target,
            "--width",
            "16",
            "--height",
            "8",
        ],
        dir,
    )
}

/// A texture baked before 1.2 lacks what the foliage model needs (leaf normals, self-shadowing,
/// wood weights): `inspect` still reads it, `render` refuses it with a message to re-bake,
/// and writes nothing.
#[test]
fn a_texel_older_than_1_2_is_refused_with_a_message_to_rebake() {
    let dir = small_forest();
    let path = dir.path().join("trees/conifer.texel");
    let t = texel_forest::formats::texel::decode(&std::fs::read(&path).unwrap()).unwrap();
    std::fs::write(&path, texel_forest::formats::texel::encode_v1_1(&t)).unwrap();
    let o = run(&["inspect", "trees/conifer.texel"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("texel 1.1"));
    let o = place_on_mountain(dir.path(), &["--region=-120,-120,120,120"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = render(dir.path(), &["-o", "old.exr"]);
    assert_error(&o, &["trees/conifer.texel", "texel 1.1", "re-bake it"]);
    assert!(!dir.path().join("old.exr").exists());
}

/// `--aov cryptomatte`: Cryptomatte's layers for species and trees, always 32-bit floats, the
/// header naming each type with its manifest; per pixel the coverages (the background's
/// included) add up to one and the objects' to the pixel's alpha. Runs make the same bytes
/// (the header's attributes in a fixed order, not a hash map's, which each process seeds).
#[test]
fn cryptomatte_layers_cover_each_pixel_by_species_and_tree() {
    use exr::prelude::{AttributeValue, FlatSamples};
    let dir = small_forest();
    for out in ["crypto.exr", "again.exr", "third.exr"] {
        let o = render(dir.path(), &["-o", out, "--half", "--aov", "cryptomatte"]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert_same_bytes(dir.path(), "crypto.exr", "again.exr");
    assert_same_bytes(dir.path(), "crypto.exr", "third.exr");
    let image =
        exr::prelude::read_all_flat_layers_from_file(dir.path().join("crypto.exr")).unwrap();
    let layer = &image.layer_data[0];
    let text = |key: &str| -> Option<String> {
        layer.attributes.other.iter().find_map(|(k, v)| match v {
            AttributeValue::Text(t) if *k == *key => {
                Some(String::from_utf8(t.bytes().to_vec()).unwrap())
            }
            _ => None,
        })
    };
    let channel = |name: &str| {
        let c = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .unwrap_or_else(|| panic!("{name} missing"));
        match &c.sample_data {
            FlatSamples::F32(v) => v.clone(),
            _ => panic!("{name} must be 32-bit float"),
        }
    };
    let alpha: Vec<f32> = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == "A")
        .unwrap()
        .sample_data
        .values_as_f32()
        .collect();
    for (name, key, prefix) in [
        ("CryptoSpecies", "7bc3981", ""),
        ("CryptoInstance", "", "/"),
    ] {
        let key = if key.is_empty() {
            format!(
                "{:08x}",
                texel_forest::cryptomatte::murmur3_32(name.as_bytes(), 0)
            )[..7]
                .to_string()
        } else {
            key.to_string()
        };
        let attr = |a: &str| text(&format!("cryptomatte/{key}/{a}")).unwrap();
        assert_eq!(attr("name"), name);
        assert_eq!(attr("hash"), "MurmurHash3_32");
        assert_eq!(attr("conversion"), "uint32_to_float32");
        let manifest: std::collections::BTreeMap<String, String> =
            serde_json::from_str(&attr("manifest")).unwrap();
        let ids: std::collections::HashMap<u32, &str> = manifest
            .iter()
            .map(|(n, h)| (u32::from_str_radix(h, 16).unwrap(), n.as_str()))
            .collect();
        assert_eq!(ids.len(), manifest.len(), "no two names share an id here");
        let ranks: Vec<(Vec<f32>, Vec<f32>)> = (0..4)
            .flat_map(|l| {
                let c = |ch: &str| channel(&format!("{name}{l:02}.{ch}"));
                [(c("R"), c("G")), (c("B"), c("A"))]
            })
            .collect();
        let mut trees = 0;
        for (i, &a) in alpha.iter().enumerate() {
            let (mut all, mut objects) = (0.0f32, 0.0f32);
            for (id, coverage) in &ranks {
                all += coverage[i];
                if id[i] != 0.0 {
                    objects += coverage[i];
                    let name = ids.get(&id[i].to_bits()).expect("every id in the manifest");
                    trees += usize::from(name.contains(prefix) && !prefix.is_empty());
                }
            }
            if ranks[7].1[i] == 0.0 {
                // Every object kept: the coverages are the whole pixel.
                assert!((all - 1.0).abs() < 2e-3, "{name} pixel {i}: {all}");
                assert!(
                    (objects - a).abs() < 2e-3,
                    "{name} pixel {i}: {objects} against {a}"
                );
            }
        }
        if prefix.is_empty() {
            assert!(manifest.contains_key("terrain") && manifest.contains_key("red pine"));
        } else {
            assert!(trees > 100, "pixels covered by trees: {trees}");
            assert!(manifest.keys().all(|n| n == "terrain" || n.contains('/')));
        }
    }
}

/// `--edge-spp` renders again the pixels at edges (here the crowns and the mountain's ridge
/// against the sky), and by default the texel and hybrid methods render the outline again:
/// against a 64-spp mesh render and a render with neither (`--edge-spp 0`), alpha's error
/// falls by a quarter or more, colour's does not rise, and the run says how many pixels it
/// rendered again (measured: texel RGB 0.0078 -> 0.0056, alpha 0.034 -> 0.023; hybrid 0.0097
/// -> 0.0054, 0.038 -> 0.020, stop 39, with --edge-spp 4). An edge count no larger than --spp is refused (exit 1, as for other flags that
/// contradict each other), and a contrast without a count or a count below 2 (exit 2).
#[test]
fn pixels_at_edges_sampled_again_soften_the_silhouettes() {
    let dir = small_forest();
    let d = dir.path();
    // Looking across the ridge, so that crowns and terrain stand against the sky.
    let render = |out: &str, extra: &[&str]| {
        let mut a = vec!["--method"];
        a.extend_from_slice(extra);
        render_128x72(d, ("--eye=-150,330,260", "0,340,0"), out, &a)
    };
    let o = render("reference.exr", &["mesh", "--spp", "64", "--jitter"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let error = |image: &str| rmse_against(d, image, "reference.exr");
    for method in ["texel", "hybrid"] {
        let o = render("once.exr", &[method, "--edge-spp", "0"]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(!stderr(&o).contains("rendered again"), "{}", stderr(&o));
        let [rgb, alpha] = error("once.exr");
        // The default renders the outline again; --edge-spp with a contrast, colour's edges too.
        for (flags, says) in [
            (&[][..], "pixels at the outline rendered again at 4 spp"),
            (
                &["--edge-spp", "4"][..],
                "pixels at edges rendered again at 4 spp",
            ),
        ] {
            let mut a = vec![method];
            a.extend_from_slice(flags);
            let o = render("edges.exr", &a);
            assert!(o.status.success(), "{}", stderr(&o));
            assert!(stderr(&o).contains(says), "{}", stderr(&o));
            let [rgb_edges, alpha_edges] = error("edges.exr");
            assert!(
                alpha_edges < 0.75 * alpha,
                "{method} {flags:?}: alpha {alpha} -> {alpha_edges}"
            );
            assert!(
                rgb_edges <= rgb,
                "{method} {flags:?}: rgb {rgb} -> {rgb_edges}"
            );
        }
    }
    let o = render("refused.exr", &["texel", "--spp", "4", "--edge-spp", "4"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("--edge-spp 4"), "{}", stderr(&o));
    assert!(!d.join("refused.exr").exists());
    // A contrast without a count, and a count below 2, are usage errors.
    for flags in [&["--edge-contrast", "0.1"][..], &["--edge-spp", "1"][..]] {
        let mut a = vec!["texel"];
        a.extend_from_slice(flags);
        let o = render("refused.exr", &a);
        assert_eq!(o.status.code(), Some(2), "{flags:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("--edge-spp"), "{}", stderr(&o));
    }
}

/// `texel inspect FRAME.exr` on a frame `texel render` wrote: its pixels within the frame, the
/// camera it was seen from (read back from `worldToCamera`), and every channel's range, with
/// Cryptomatte's id channels told apart and no NaN anywhere; a picture asked of it is refused.
#[test]
fn inspect_summarises_a_rendered_frame() {
    let dir = small_forest();
    let o = render(
        dir.path(),
        &[
            "-o",
            "crop.exr",
            "--crop",
            "8,4,40,30",
            "--aov",
            "cryptomatte,normal",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&["inspect", "crop.exr"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("OpenEXR frame (written by texel-forest")
            && text.contains("pixels        32 x 26 at (8, 4) of the frame 64 x 36 at (0, 0)")
            && text.contains("(Cryptomatte ids)"),
        "{text}"
    );
    let o = run(&["inspect", "crop.exr", "--json"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let eye: Vec<f64> = (0..3)
        .map(|k| json["camera"]["eye"][k].as_f64().unwrap())
        .collect();
    let forward: Vec<f64> = (0..3)
        .map(|k| json["camera"]["forward"][k].as_f64().unwrap())
        .collect();
    let (e, target) = ([-150.0, 450.0, 260.0], [0.0, 300.0, 0.0]);
    let to: Vec<f64> = (0..3).map(|k| target[k] - e[k]).collect();
    let length = to.iter().map(|x| x * x).sum::<f64>().sqrt();
    for k in 0..3 {
        assert!((eye[k] - e[k]).abs() < 1e-2, "eye {eye:?}");
        assert!(
            (forward[k] - to[k] / length).abs() < 1e-4,
            "forward {forward:?}"
        );
    }
    let channels = json["channels"].as_array().unwrap();
    let find = |name: &str| {
        channels
            .iter()
            .find(|c| c["name"] == name)
            .unwrap_or_else(|| panic!("no channel {name} in {channels:?}"))
    };
    for name in ["R", "G", "B", "A", "Z", "N.X", "CryptoSpecies00.G"] {
        let c = find(name);
        assert_eq!(c["ids"], false, "{c}");
        assert!(
            c["min"].as_f64().unwrap() <= c["max"].as_f64().unwrap(),
            "{c}"
        );
    }
    let alpha = find("A");
    assert!(alpha["min"].as_f64().unwrap() >= 0.0 && alpha["max"].as_f64().unwrap() <= 1.0);
    assert_eq!(find("CryptoSpecies00.R")["ids"], true);
    assert_eq!(find("CryptoInstance00.B")["ids"], true);
    for c in channels {
        let ids = c["ids"] == true;
        assert!(
            ids == c["nan"].is_null() && ids == c["infinite"].is_null(),
            "{c}"
        );
        assert!(ids || c["nan"] == 0, "{c}");
    }
    assert!(
        json["attributes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|kv| kv[1] == "CryptoSpecies"),
        "{json}"
    );
    let o = run(
        &["inspect", "crop.exr", "--map", "-o", "map.png"],
        dir.path(),
    );
    assert_error(&o, &["crop.exr", "frame", "--map"]);
    assert!(!dir.path().join("map.png").exists());
    // A heightmap flag reads even a frame as a heightmap (its R channel, in metres).
    let o = run(
        &["inspect", "crop.exr", "--terrain-size", "100,100"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        !text.contains("OpenEXR frame") && text.contains("raster"),
        "{text}"
    );
}

/// The film holds a crop's pixels alone, so a frame's memory is judged by them: a one-pixel
/// crop of a frame whose every layer would take 40 GB renders. (That a crop too large for
/// the machine is refused by name is not tested: where the kernel overcommits, the probe
/// would succeed and start a 256-million-pixel render.)
#[test]
fn a_crops_memory_is_its_own_pixels() {
    let dir = small_forest();
    let aovs = "normal,albedo,canopy,species,lod,samples,cryptomatte";
    let o = run(
        &[
            "render",
            "forest.instances",
            "-o",
            "one.exr",
            "--width",
            "8192",
            "--height",
            "8192",
            "--aov",
            aovs,
            "--crop",
            "0,0,1,1",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
}
