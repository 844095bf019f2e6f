//! Careless and hostile use of the CLI, end to end: outputs that clash with inputs or with each
//! other, devices, links, interrupted runs, endless and oversized inputs, absurd flag values,
//! stale sources, non-finite pixels. Each test guards a defect a user met (issue 9).

mod common;

use std::path::Path;

use common::*;

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn usage_error(o: &std::process::Output, needle: &str) {
    assert_eq!(o.status.code(), Some(2), "{}", stderr(o));
    assert!(
        stderr(o).contains(needle),
        "{needle:?} not in {}",
        stderr(o)
    );
}

#[test]
fn an_output_that_is_an_input_or_another_output_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let tree = std::fs::read(fixture("trees/conifer.glb")).unwrap();
    std::fs::write(dir.path().join("t.glb"), &tree).unwrap();
    assert_error(
        &run(&["bake", "t.glb", "-o", "t.glb"], dir.path()),
        &["-o t.glb", "is also an input"],
    );
    assert_error(
        &run(&["bake", "t.glb", "-o", "./sub/../t.glb"], dir.path()),
        &["is also an input"],
    );
    assert_error(
        &run(
            &["bake", "t.glb", "-o", "a.texel", "--depfile", "a.texel"],
            dir.path(),
        ),
        &["--depfile a.texel", "is also the output of -o"],
    );
    assert_eq!(std::fs::read(dir.path().join("t.glb")).unwrap(), tree);
    assert_eq!(files_in(dir.path()), ["t.glb"]);

    // A glTF's buffer is an input too, found only once the glTF is read.
    let gltf = fixture("trees/broadleaf.gltf");
    let o = run(
        &[
            "bake",
            gltf.to_str().unwrap(),
            "-o",
            "b.texel",
            "--depfile",
            fixture("trees/broadleaf.bin").to_str().unwrap(),
        ],
        dir.path(),
    );
    assert_error(&o, &["broadleaf.bin", "is also an input"]);

    let forest = small_forest();
    let o = render(forest.path(), &["-o", "f.exr", "--preview", "f.exr"]);
    assert_error(&o, &["--preview f.exr", "is also the output of -o"]);
    let o = render(forest.path(), &["-o", "forest.instances"]);
    assert_error(&o, &["is also an input"]);
}

#[cfg(unix)]
#[test]
fn devices_are_written_in_place_and_links_keep_pointing_at_their_file() {
    let dir = tempfile::tempdir().unwrap();
    let tree = fixture("trees/conifer.glb");
    let t = tree.to_str().unwrap();
    let o = run(
        &["bake", t, "-o", "/dev/null", "--resolution", "8"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    use std::os::unix::fs::FileTypeExt;
    assert!(
        std::fs::metadata("/dev/null")
            .unwrap()
            .file_type()
            .is_char_device()
    );
    if Path::new("/dev/full").exists() {
        let o = run(
            &["bake", t, "-o", "/dev/full", "--resolution", "8"],
            dir.path(),
        );
        assert_error(&o, &["/dev/full", "No space left"]);
    }
    std::fs::write(dir.path().join("real.texel"), b"old").unwrap();
    std::os::unix::fs::symlink("real.texel", dir.path().join("link.texel")).unwrap();
    let o = run(
        &["bake", t, "-o", "link.texel", "--resolution", "8"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let link = std::fs::symlink_metadata(dir.path().join("link.texel")).unwrap();
    assert!(link.file_type().is_symlink(), "the link stays a link");
    assert!(
        std::fs::read(dir.path().join("real.texel"))
            .unwrap()
            .starts_with(b"\x89TEXEL")
    );
}

#[test]
fn a_bad_secondary_output_fails_before_the_render_and_keeps_the_old_frame() {
    let dir = small_forest();
    std::fs::write(dir.path().join("good.exr"), b"old").unwrap();
    std::fs::create_dir(dir.path().join("adir")).unwrap();
    let o = render(dir.path(), &["-o", "good.exr", "--preview", "adir"]);
    assert_error(&o, &["--preview adir", "is a directory"]);
    assert!(!stderr(&o).contains("rendered"));
    assert_eq!(std::fs::read(dir.path().join("good.exr")).unwrap(), b"old");
    // An output whose directory cannot be created fails at once, not after the render.
    std::fs::write(dir.path().join("plain"), b"x").unwrap();
    let o = render(dir.path(), &["-o", "plain/x.exr"]);
    assert_error(&o, &["-o plain/x.exr", "cannot create directory"]);
}

#[cfg(unix)]
#[test]
fn interrupted_runs_leave_nothing_and_stale_temporaries_are_swept() {
    let dir = small_forest();
    let before = files_in(dir.path());
    let mut child = texel()
        .args([
            "render",
            "forest.instances",
            "-o",
            "big.exr",
            "--preview",
            "big.png",
        ])
        .args(["--width", "1600", "--height", "1200", "--spp", "16"])
        .current_dir(dir.path())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(600));
    let killed = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130), "{status:?}");
    assert_eq!(files_in(dir.path()), before, "no output and no temporary");

    // A run killed with SIGKILL while writing leaves a temporary; the next run sweeps it.
    std::fs::write(dir.path().join(".small.exr.2147483646.tmp"), b"partial").unwrap();
    let o = render(dir.path(), &["-o", "small.exr"]);
    assert!(o.status.success(), "{}", stderr(&o));
    if cfg!(target_os = "linux") {
        assert!(!dir.path().join(".small.exr.2147483646.tmp").exists());
    }
}

#[cfg(unix)]
#[test]
fn endless_inputs_are_refused_without_reading_them_whole() {
    if !Path::new("/dev/zero").exists() {
        return;
    }
    let dir = small_forest();
    assert_error(
        &run(&["bake", "/dev/zero", "-o", "z.texel"], dir.path()),
        &["/dev/zero", "not a glTF file"],
    );
    assert_error(
        &run(&["render", "/dev/zero", "-o", "z.exr"], dir.path()),
        &["/dev/zero", "not an instances file"],
    );
    assert_error(
        &run(&["inspect", "/dev/zero"], dir.path()),
        &["/dev/zero", "not a .texel, .instances or glTF terrain"],
    );
    let terrain = fixture("terrain/mountain.glb");
    let t = terrain.to_str().unwrap();
    assert_error(
        &run(
            &["place", t, "--species", "/dev/zero", "-o", "z.instances"],
            dir.path(),
        ),
        &[
            "/dev/zero",
            "larger than the 16777216 bytes a species file may have",
        ],
    );
    let mut species: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("species.json")).unwrap()).unwrap();
    species["species"][0]["texel"] = serde_json::json!("/dev/zero");
    std::fs::write(dir.path().join("zero.json"), species.to_string()).unwrap();
    assert_error(
        &run(
            &["place", t, "--species", "zero.json", "-o", "z.instances"],
            dir.path(),
        ),
        &["species[0].texel", "not a texel file"],
    );
}

/// A glTF buffer that names an endless file (`/dev/zero` here) with a huge `byteLength` is
/// refused by what it declares, before it is read.
#[cfg(unix)]
#[test]
fn a_gltf_buffer_that_declares_too_much_is_refused_before_it_is_read() {
    if !Path::new("/dev/zero").exists() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink("/dev/zero", dir.path().join("zero.bin")).unwrap();
    let gltf = serde_json::json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 } }] }],
        "accessors": [{ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                        "min": [0, 0, 0], "max": [1, 1, 1] }],
        "bufferViews": [{ "buffer": 0, "byteLength": 36 }],
        "buffers": [{ "uri": "zero.bin", "byteLength": 1_u64 << 40 }],
    });
    std::fs::write(dir.path().join("tree.gltf"), gltf.to_string()).unwrap();
    assert_error(
        &run(&["bake", "tree.gltf", "-o", "tree.texel"], dir.path()),
        &[
            "tree.gltf",
            "buffers[0].byteLength",
            "1099511627776 bytes",
            "in all",
        ],
    );
    assert!(!dir.path().join("tree.texel").exists());
}

/// A texture of 300^3 cells, all zero, compresses to kilobytes but is gigabytes once read: the
/// default cell limit refuses it from its header (the invalid corpus's bomb, read through the
/// CLI), and the bake refuses to make a texture the readers would refuse.
#[test]
fn a_texture_bomb_is_refused_from_its_header() {
    let dir = small_forest();
    let bomb = fixture("formats/invalid/texel-cells-over-the-default-limit.texel");
    let o = run(&["inspect", bomb.to_str().unwrap()], dir.path());
    assert_error(
        &o,
        &[
            "texel-cells-over-the-default-limit.texel",
            "cell count (all levels) is 30859767",
            "--max-cells",
        ],
    );
    let conifer = fixture("trees/conifer.glb");
    let o = run(
        &[
            "bake",
            conifer.to_str().unwrap(),
            "-o",
            "big.texel",
            "--resolution",
            "256",
            "--fine",
            "512",
        ],
        dir.path(),
    );
    assert_error(
        &o,
        &[
            "--resolution 256",
            "over the limit of 4194304",
            "--max-cells",
        ],
    );
    assert!(!dir.path().join("big.texel").exists());
}

#[test]
fn small_files_that_claim_much_are_refused_by_the_limits() {
    let dir = small_forest();
    assert_error(
        &run(
            &["inspect", "trees/conifer.texel", "--max-cells", "100"],
            dir.path(),
        ),
        &[
            "trees/conifer.texel",
            "over the limit of 100",
            "--max-cells",
        ],
    );
    assert_error(
        &run(
            &["inspect", "forest.instances", "--max-trees", "10"],
            dir.path(),
        ),
        &["forest.instances", "over the limit of 10", "--max-trees"],
    );
    // Nor can a limit be raised past what one hierarchy can index: a usage error, not a
    // panic once a file that large is read.
    for flag in ["--max-trees", "--max-triangles"] {
        usage_error(
            &run(
                &["inspect", "forest.instances", flag, "600000000"],
                dir.path(),
            ),
            "the most one hierarchy can index",
        );
    }
    // A species file that asks for forty million trees stops at the limit, not at the end.
    let mut dense: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("species.json")).unwrap()).unwrap();
    for s in dense["species"].as_array_mut().unwrap() {
        s["spacing"] = serde_json::json!(0.1);
    }
    std::fs::write(dir.path().join("dense.json"), dense.to_string()).unwrap();
    let t = fixture("terrain/mountain.glb");
    let o = run(
        &[
            "place",
            t.to_str().unwrap(),
            "--species",
            "dense.json",
            "-o",
            "dense.instances",
            "--max-trees",
            "1000",
        ],
        dir.path(),
    );
    assert_error(
        &o,
        &[
            "tree count is 1001",
            "over the limit of 1000",
            "--max-trees",
        ],
    );
    // A 40 kB glTF that instances a 1,000-triangle mesh 20,000 times: 20 million triangles.
    strip_drawn_by_nodes(dir.path(), "bomb", 20_000);
    let o = run(&["bake", "bomb.gltf", "-o", "bomb.texel"], dir.path());
    assert_error(
        &o,
        &["bomb.gltf", "over the limit of 16777216", "--max-triangles"],
    );
}

#[test]
fn absurd_sizes_and_values_are_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    // The frame is judged before the (missing) forest is even opened.
    let o = run(
        &[
            "render",
            "missing.instances",
            "-o",
            "x.exr",
            "--width",
            "65535",
            "--height",
            "65535",
        ],
        dir.path(),
    );
    assert_error(&o, &["--width x --height", "4294836225", "--max-pixels"]);
    let render = |flags: &[&str]| {
        let mut a = vec!["render", "missing.instances", "-o", "x.exr"];
        a.extend_from_slice(flags);
        run(&a, dir.path())
    };
    usage_error(&render(&["--width", "100000"]), "--width");
    usage_error(&render(&["--threads", "10000"]), "--threads");
    usage_error(&render(&["--crop", "NaN,0,4,4"]), "--crop");
    usage_error(&render(&["--crop=-1,0,4,4"]), "--crop");
    usage_error(&render(&["--crop", "0.5,0,4,4"]), "--crop");
    usage_error(&render(&["--sky", "1e39,0,0"]), "--sky");
    usage_error(&render(&["--eye", "0,0,inf", "--target", "1,1,1"]), "--eye");
    usage_error(&render(&["--fov", "179.5"]), "--fov");
    usage_error(&render(&["--fov", "1e-40"]), "--fov");
    // Each bake size out of its range is a usage error too; a --fine that is no multiple of
    // --resolution contradicts it, an input error naming both.
    let bake = |flags: &[&str]| {
        let mut a = vec!["bake", "missing.glb", "-o", "x.texel"];
        a.extend_from_slice(flags);
        run(&a, dir.path())
    };
    usage_error(&bake(&["--resolution", "0"]), "--resolution");
    usage_error(&bake(&["--fine", "5000"]), "--fine");
    let o = bake(&["--fine", "12"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("--fine 12") && stderr(&o).contains("--resolution 32"));
    usage_error(&render(&["--fov", "180"]), "--fov");
    // A march's work grows as 1 / step: 1e-30 would never finish (1e-50 is 0 as f32).
    usage_error(&render(&["--step", "1e-30"]), "--step");
    usage_error(&render(&["--step", "1e-50"]), "--step");
    usage_error(
        &run(
            &["compare", "a.exr", "b.exr", "--fail-above", "NaN"],
            dir.path(),
        ),
        "--fail-above",
    );
    usage_error(
        &run(
            &[
                "bake",
                "t.glb",
                "-o",
                "t.texel",
                "--density",
                "occupancy",
                "--gamma",
                "1e308",
            ],
            dir.path(),
        ),
        "--gamma",
    );
    assert!(files_in(dir.path()).is_empty());
}

#[test]
fn a_huge_topographic_radius_and_heights_beyond_the_stored_scale_are_handled() {
    let dir = small_forest();
    let base: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("species.json")).unwrap()).unwrap();
    let mut wide = base.clone();
    wide["analysis"]["tpi_radius"] = serde_json::json!(1e308);
    std::fs::write(dir.path().join("wide.json"), wide.to_string()).unwrap();
    let terrain = fixture("terrain/mountain.glb");
    let t = terrain.to_str().unwrap();
    let o = run(
        &["place", t, "--species", "wide.json", "-o", "wide.instances"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));

    // Trees a thousand kilometres tall cannot be stored as scales of their models: the
    // species file's heights are refused by field when it is read, however they are spaced,
    // and nothing is written.
    for (name, spacing) in [("giant", 1e5), ("tall", 10.0)] {
        let mut giant = base.clone();
        for s in giant["species"].as_array_mut().unwrap() {
            s["height"] = serde_json::json!({ "min": 1e6, "max": 1e6 });
            s["spacing"] = serde_json::json!(spacing);
        }
        let file = format!("{name}.json");
        std::fs::write(dir.path().join(&file), giant.to_string()).unwrap();
        let out = format!("{name}.instances");
        let o = run(&["place", t, "--species", &file, "-o", &out], dir.path());
        assert_error(
            &o,
            &[&format!("{file}: species[0].height"), "1000000", "2^16"],
        );
        assert!(!dir.path().join(&out).exists());
    }
}

#[test]
fn every_file_of_the_terrain_is_checked_not_only_the_gltf() {
    let dir = tempfile::tempdir().unwrap();
    species_with_texels(dir.path());
    let files =
        texel_forest::procedural::terrain::mountain(300.0, 33, 5).to_gltf(Some("hill"), "t");
    std::fs::write(dir.path().join("hill.bin"), &files.bin).unwrap();
    let mut doc = files.doc.clone();
    doc["buffers"][0]["uri"] = serde_json::json!("hill.bin");
    std::fs::write(dir.path().join("hill.gltf"), doc.to_string()).unwrap();
    let o = run(
        &[
            "place",
            "hill.gltf",
            "--species",
            "species.json",
            "-o",
            "forest.instances",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let mut bin = files.bin.clone();
    let last = bin.len() - 1;
    bin[last] ^= 0x55;
    std::fs::write(dir.path().join("hill.bin"), bin).unwrap();
    let o = run(
        &[
            "render",
            "forest.instances",
            "-o",
            "x.exr",
            "--width",
            "8",
            "--height",
            "8",
        ],
        dir.path(),
    );
    assert_error(
        &o,
        &[
            "forest.instances",
            "hill.bin",
            "changed since the forest was placed",
            "re-run texel place",
        ],
    );
}

/// An OpenEXR file of `pixels` (RGBA, float).
fn write_exr(path: &Path, width: usize, pixels: &[[f32; 4]]) {
    use exr::prelude::*;
    let height = pixels.len() / width;
    let channel = |c: usize, name: &str| {
        AnyChannel::new(
            name,
            FlatSamples::F32(pixels.iter().map(|p| p[c]).collect()),
        )
    };
    let layer = Layer::new(
        (width, height),
        LayerAttributes::default(),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(
            vec![
                channel(0, "R"),
                channel(1, "G"),
                channel(2, "B"),
                channel(3, "A"),
            ]
            .into(),
        ),
    );
    Image::from_layer(layer).write().to_file(path).unwrap();
}

#[test]
fn non_finite_pixels_fail_compare_and_never_reach_our_images() {
    let dir = small_forest();
    write_exr(
        &dir.path().join("nan.exr"),
        2,
        &[[f32::NAN, 0.0, 0.0, 1.0]; 4],
    );
    let o = run(
        &["compare", "nan.exr", "nan.exr", "--fail-above", "1"],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("not finite"), "{}", stderr(&o));

    // A sky brighter than half floats hold: clamped with a warning, no infinity written.
    let o = render(
        dir.path(),
        &[
            "-o",
            "bright.exr",
            "--half",
            "--sky",
            "100000,100000,100000",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("clamped"), "{}", stderr(&o));
    let image =
        exr::prelude::read_all_flat_layers_from_file(dir.path().join("bright.exr")).unwrap();
    // Depth is +infinity over the sky, by definition; everything else must be finite.
    for channel in &image.layer_data[0].channel_data.list {
        if channel.name.to_string() == "Z" {
            continue;
        }
        assert!(
            channel.sample_data.values_as_f32().all(f32::is_finite),
            "{}",
            channel.name
        );
    }
}

#[test]
fn every_pixel_with_coverage_has_a_finite_depth_and_only_those() {
    let dir = small_forest();
    // Low over the forest towards the horizon: crowns stand against the sky.
    let o = run(
        &[
            "render",
            "forest.instances",
            "-o",
            "d.exr",
            "--eye=-150,400,150",
            "--target",
            "150,470,-150",
            "--width",
            "96",
            "--height",
            "54",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let image = exr::prelude::read_all_flat_layers_from_file(dir.path().join("d.exr")).unwrap();
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
    let (a, z) = (channel("A"), channel("Z"));
    let partial = a.iter().filter(|&&a| a > 0.0 && a < 0.5).count();
    assert!(partial > 0, "the view must show faint edges over the sky");
    for (i, (&a, &z)) in a.iter().zip(&z).enumerate() {
        assert_eq!(a > 0.0, z.is_finite(), "pixel {i}: alpha {a}, depth {z}");
    }
}

#[test]
fn inspect_of_a_clustered_forest_is_not_quadratic() {
    use texel_forest::formats::instances;
    let dir = tempfile::tempdir().unwrap();
    let golden = std::fs::read(fixture("formats/forest-12.instances")).unwrap();
    let mut forest = instances::decode(&golden).unwrap();
    let one = forest.instances[0];
    forest.instances = vec![one; 100_000];
    std::fs::write(
        dir.path().join("pile.instances"),
        instances::encode(&forest).unwrap(),
    )
    .unwrap();
    let start = std::time::Instant::now();
    let o = run(&["inspect", "pile.instances"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("closest pair 0.00 m"), "{text}");
    // Not a timing claim: a quadratic scan of these trees takes tens of seconds.
    eprintln!("inspect of 100,000 coincident trees: {:?}", start.elapsed());
}

/// Values no forest has but a file can hold (a region and trees a trillion light years
/// across, positions of 1e300) are printed as numbers a person can read, not as hundreds of
/// digits.
#[test]
fn inspect_prints_huge_values_in_a_few_characters() {
    use texel_forest::formats::instances;
    let dir = tempfile::tempdir().unwrap();
    let golden = std::fs::read(fixture("formats/forest-12.instances")).unwrap();
    let mut forest = instances::decode(&golden).unwrap();
    forest.info.region = [-1e300, -1e300, 1e300, 1e300];
    forest.info.species[0].spacing = 1e300;
    forest.info.origin = [1e300, 1e300, -1e300];
    for t in &mut forest.instances {
        t.position = forest.info.origin;
    }
    forest.heightmap = Some(instances::HeightmapOptions {
        size: Some([1e300, 2.5]),
        height_range: Some([-1e-300, 1e300]),
    });
    let bytes = instances::encode(&forest).unwrap_or_else(|e| panic!("{e}"));
    std::fs::write(dir.path().join("huge.instances"), bytes).unwrap();
    let o = run(&["inspect", "huge.instances"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("-1.0e300 .. 1.0e300"), "{text}");
    assert!(text.contains("1e300 x 2.5 m (--terrain-size)"), "{text}");
    for line in text.lines() {
        assert!(
            line.len() < 200,
            "a line of {} characters: {line}",
            line.len()
        );
    }
}

/// An OpenEXR header for a `width` x `height` RGBA float image, with no pixel data after it.
fn exr_header_only(width: i32, height: i32) -> Vec<u8> {
    let mut b = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    let mut attribute = |name: &str, kind: &str, value: &[u8]| {
        b.extend_from_slice(name.as_bytes());
        b.push(0);
        b.extend_from_slice(kind.as_bytes());
        b.push(0);
        b.extend_from_slice(&(value.len() as i32).to_le_bytes());
        b.extend_from_slice(value);
    };
    let mut channels = Vec::new();
    for name in ["A", "B", "G", "R"] {
        channels.extend_from_slice(name.as_bytes());
        channels.push(0);
        channels.extend_from_slice(&2i32.to_le_bytes()); // FLOAT
        channels.extend_from_slice(&[0, 0, 0, 0]);
        channels.extend_from_slice(&1i32.to_le_bytes());
        channels.extend_from_slice(&1i32.to_le_bytes());
    }
    channels.push(0);
    attribute("channels", "chlist", &channels);
    attribute("compression", "compression", &[0]);
    let window = [0, 0, width - 1, height - 1]
        .iter()
        .flat_map(|v: &i32| v.to_le_bytes())
        .collect::<Vec<u8>>();
    attribute("dataWindow", "box2i", &window);
    attribute("displayWindow", "box2i", &window);
    attribute("lineOrder", "lineOrder", &[0]);
    attribute("pixelAspectRatio", "float", &1f32.to_le_bytes());
    attribute("screenWindowCenter", "v2f", &[0; 8]);
    attribute("screenWindowWidth", "float", &1f32.to_le_bytes());
    b.push(0);
    b
}

#[test]
fn compare_refuses_a_tiny_exr_that_claims_ten_billion_pixels() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("huge.exr"),
        exr_header_only(100_000, 100_000),
    )
    .unwrap();
    write_exr(&dir.path().join("small.exr"), 2, &[[0.0; 4]; 4]);
    let o = run(&["compare", "huge.exr", "small.exr"], dir.path());
    assert_error(&o, &["huge.exr", "10000000000", "--max-pixels"]);
}

#[test]
fn damaged_files_are_named_by_their_kind_and_names_cannot_drive_the_terminal() {
    let dir = tempfile::tempdir().unwrap();
    let mut forest = std::fs::read(fixture("formats/forest-12.instances")).unwrap();
    forest[0] = b'X';
    std::fs::write(dir.path().join("f.instances"), &forest).unwrap();
    assert_error(
        &run(&["inspect", "f.instances"], dir.path()),
        &["not an instances file", "the first byte was altered"],
    );
    // A material named with an escape sequence that would turn the terminal red.
    let tetra = [
        [0.0f32, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let bin: Vec<u8> = tetra
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let indices: Vec<u8> = [0u16, 1, 2, 0, 2, 3, 0, 3, 1, 1, 3, 2]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let all = [bin.clone(), indices.clone()].concat();
    let doc = serde_json::json!({
        "asset": { "version": "2.0" },
        "scenes": [{ "nodes": [0] }], "nodes": [{ "mesh": 0 }],
        "materials": [{ "name": "bark\u{1b}[31m" }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 }, "indices": 1, "material": 0 }] }],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3" },
            { "bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR" }
        ],
        "bufferViews": [
            { "buffer": 0, "byteLength": bin.len() },
            { "buffer": 0, "byteOffset": bin.len(), "byteLength": indices.len() }
        ],
        "buffers": [{ "byteLength": all.len(), "uri": "t.bin" }],
    });
    std::fs::write(dir.path().join("t.bin"), &all).unwrap();
    std::fs::write(dir.path().join("t.gltf"), doc.to_string()).unwrap();
    let o = run(
        &[
            "bake",
            "t.gltf",
            "-o",
            "t.texel",
            "--resolution",
            "4",
            "--fine",
            "8",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&["inspect", "t.texel"], dir.path());
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(!text.contains('\u{1b}'), "{text:?}");
    assert!(text.contains("bark\\u{1b}[31m"), "{text}");
}

#[test]
fn a_texture_beyond_the_renderers_f32_range_is_refused_naming_it() {
    // Valid (its numbers are f64), but infinite in the renderer's f32: it drew nothing.
    let dir = small_forest();
    let first = Path::new(FIXTURE_TREES[0])
        .file_stem()
        .unwrap()
        .to_string_lossy()
        .into_owned();
    let path = dir.path().join(format!("trees/{first}.texel"));
    let bytes = texel_forest::formats::container::read_file(&path).unwrap();
    let mut t = texel_forest::formats::texel::decode(&bytes).unwrap();
    // A power of two keeps each level's cell exactly twice the last's.
    for l in &mut t.levels {
        l.cell *= 2f64.powi(1000);
    }
    std::fs::write(&path, texel_forest::formats::texel::encode(&t).unwrap()).unwrap();
    let o = place_on_mountain(dir.path(), &["--region=-120,-120,120,120"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = render(dir.path(), &["-o", "big.exr"]);
    assert_error(&o, &[&format!("{first}.texel"), "beyond the 1e30"]);
    assert!(!dir.path().join("big.exr").exists());
}

/// A forest placed for a model of another height than its texture's is refused, the two
/// heights printed as numbers a person reads (1e-300 was printed as 300 digits).
#[test]
fn a_forest_placed_for_another_model_height_is_refused_in_few_words() {
    use texel_forest::formats::instances;
    let dir = small_forest();
    let placed = std::fs::read(dir.path().join("forest.instances")).unwrap();
    let mut forest = instances::decode(&placed).unwrap();
    forest.info.species[0].model_height = 1e-300;
    std::fs::write(
        dir.path().join("odd.instances"),
        instances::encode(&forest).unwrap(),
    )
    .unwrap();
    let mut args = vec!["render", "odd.instances", "-o", "odd.exr"];
    args.extend_from_slice(&VIEW);
    let o = run(&args, dir.path());
    assert_error(
        &o,
        &[
            "odd.instances: species",
            "the forest was placed for one 1e-300 m tall; re-run texel place",
        ],
    );
    assert!(stderr(&o).len() < 300, "{}", stderr(&o));
    assert!(!dir.path().join("odd.exr").exists());
}

/// A hand-made forest that piles trees on one spot (`place` never does) is refused before
/// anything is built: a ray inside all their boxes at once pays for each (100,000 such trees
/// took a 64 x 36 render 9 s, a million over a minute). The error names the file, the tree,
/// where it stands and the flag, and writes nothing; the flag lets a smaller pile through.
#[test]
fn a_pile_of_trees_on_one_spot_is_refused_by_render() {
    use texel_forest::formats::instances;
    let dir = small_forest();
    let placed = std::fs::read(dir.path().join("forest.instances")).unwrap();
    let mut forest = instances::decode(&placed).unwrap();
    let (count, one) = (forest.instances.len(), forest.instances[0]);
    forest.instances.extend(std::iter::repeat_n(one, 100_000));
    let pile = dir.path().join("pile.instances");
    std::fs::write(&pile, instances::encode(&forest).unwrap()).unwrap();
    let render_pile = |extra: &[&str]| {
        let mut args = vec!["render", "pile.instances", "-o", "pile.exr"];
        args.extend_from_slice(&VIEW);
        args.extend_from_slice(extra);
        run(&args, dir.path())
    };
    let o = render_pile(&[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    for part in [
        "pile.instances: the number of trees standing over the base of tree 0 (x ",
        "over the limit of 1024 (raise it with --max-overlap)",
    ] {
        assert!(e.contains(part), "{e}");
    }
    assert!(!dir.path().join("pile.exr").exists());

    forest.instances.truncate(count + 2000);
    std::fs::write(&pile, instances::encode(&forest).unwrap()).unwrap();
    assert!(!render_pile(&[]).status.success());
    let o = render_pile(&["--max-overlap", "4096"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A glTF whose nodes draw one mesh many times at one place (within `--max-triangles`) would
/// have every copy cross every ray of the bake's columns, all held at once: 1,000 copies of a
/// 1,000-triangle strip took 1.5 GB. The bake refuses it before scanning, naming the file and
/// the problem, and writes nothing.
#[test]
fn a_mesh_piled_on_itself_by_its_nodes_is_refused_by_bake() {
    let dir = tempfile::tempdir().unwrap();
    strip_drawn_by_nodes(dir.path(), "pile", 200);
    let o = run(&["bake", "pile.gltf", "-o", "pile.texel"], dir.path());
    assert_error(
        &o,
        &[
            "pile.gltf",
            "holds 200000 triangles",
            "over the limit of 65536",
            "piles surfaces on one spot",
        ],
    );
    assert!(!dir.path().join("pile.texel").exists());
}

/// `NAME.gltf` and `NAME.bin` in `dir`: a 1,000-triangle strip (10 m long) drawn at one place
/// by each of `nodes` nodes, all in the scene.
fn strip_drawn_by_nodes(dir: &Path, name: &str, nodes: usize) {
    let strip: Vec<[f32; 3]> = (0..1002)
        .map(|i| [i as f32 * 0.01, (i % 2) as f32, (i % 3) as f32 * 0.1])
        .collect();
    let bin: Vec<u8> = strip
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let doc = serde_json::json!({
        "asset": { "version": "2.0" },
        "scenes": [{ "nodes": (0..nodes).collect::<Vec<_>>() }],
        "nodes": (0..nodes).map(|_| serde_json::json!({ "mesh": 0 })).collect::<Vec<_>>(),
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 }, "mode": 5 }] }],
        "accessors": [{
            "bufferView": 0, "componentType": 5126, "count": 1002, "type": "VEC3",
            "min": [0.0, 0.0, 0.0], "max": [10.01, 1.0, 0.2],
        }],
        "bufferViews": [{ "buffer": 0, "byteLength": bin.len() }],
        "buffers": [{ "byteLength": bin.len(), "uri": format!("{name}.bin") }],
    });
    std::fs::write(dir.join(format!("{name}.bin")), &bin).unwrap();
    std::fs::write(dir.join(format!("{name}.gltf")), doc.to_string()).unwrap();
}

/// A standard error nobody reads any more (`2>&1 | head -1` after its first line, a closed
/// pipe) loses the message, not the exit status: 1 for an error, where `eprintln!` panicked
/// with 101.
#[test]
fn a_closed_standard_error_keeps_the_exit_status() {
    let dir = tempfile::tempdir().unwrap();
    // The pipe's reader is gone before texel starts: its every write to stderr fails.
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let status = common::texel()
        .args(["bake", "missing.glb", "-o", "x.texel"])
        .current_dir(dir.path())
        .stdout(std::process::Stdio::null())
        .stderr(writer)
        .status()
        .unwrap();
    assert_eq!(status.code(), Some(1));
    assert!(!dir.path().join("x.texel").exists());
}

/// The occupancy model votes over every fine cell of the three axes' scans, three bytes a
/// fine cell: `--fine 4096` on the conifer's grid would take 57 GiB, and at 2048 (7.2 GiB) a
/// process held to 6 GiB aborted on an allocation failure, an abort where an error was due.
/// The bake refuses such a grid before scanning, naming the file, the flags and the memory,
/// and writes nothing.
#[test]
fn an_occupancy_bake_too_fine_for_memory_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(fixture("trees/conifer.glb"), dir.path().join("conifer.glb")).unwrap();
    let o = run(
        &[
            "bake",
            "conifer.glb",
            "-o",
            "c.texel",
            "--density",
            "occupancy",
            "--fine",
            "2048",
        ],
        dir.path(),
    );
    assert_error(
        &o,
        &[
            "conifer.glb",
            "--density occupancy",
            "--fine 2048",
            "1152 x 2048 x 1088",
            "7.2 GiB",
        ],
    );
    assert!(!dir.path().join("c.texel").exists());
}
