//! `make report`: speed against error, the paper's claim measured.
//!
//! On the demo forest (the fixture trees on the fixture mountain) seen from afar (the paper's
//! case), from the middle distance and from near, every way of rendering is timed and its
//! error measured against a mesh render at many samples per pixel (the ground truth, cached
//! under `report/cache/` so reruns are fast): the mesh method at 1 to 64 spp; the texel method
//! with both density models at 16, 32 and 64 cells and 1 and 4 spp; and every setting of the
//! texel renderer that trades speed for error; the hybrid method at 1 to 16 spp and every
//! setting of its switch. Then flicker: the far view rendered with sub-pixel camera jitter,
//! and the mean per-pixel standard deviation across the frames; and a sweep of the camera
//! from the far view to the near one, the hybrid method at 1 spp against a mesh reference at
//! each step.
//!
//! Then the error budget (`budget.rs`): the texel method's error split into coverage,
//! shading, shadows and noise. `make budget` runs that part alone.
//!
//! Writes `report/speed_vs_error.csv`, `report/README.md` (tables and the headline),
//! `report/speed_vs_error_<view>.png` and `report/error_budget.{md,csv,png}`. Everything runs through the `texel` binary, as a user's
//! build would.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

mod budget;
mod flyin;

use sha2::{Digest, Sha256};
use texel_forest::compare::{Rgba, compare};
use texel_forest::hex::hex;
use texel_forest::plot::{PALETTE, Plot, Series};

const WIDTH: u32 = 480;
const HEIGHT: u32 = 270;
const REFERENCE_SPP: u32 = 256;
const FLICKER_FRAMES: usize = 8;
const TREES: [(&str, &str); 3] = [
    ("conifer", "conifer.glb"),
    ("broadleaf", "broadleaf.gltf"),
    ("bare", "bare.glb"),
];

struct View<'a> {
    name: &'a str,
    flags: &'a [&'a str],
}

const VIEWS: [View<'static>; 3] = [
    // The default framing: the whole mountain from 1.5 km (the paper's figure 6).
    View {
        name: "far",
        flags: &[],
    },
    View {
        name: "middle",
        flags: &["--eye=-350,600,650", "--target", "0,300,0", "--fov", "40"],
    },
    View {
        name: "near",
        flags: &["--eye=-110,420,190", "--target", "0,330,40", "--fov", "40"],
    },
];

/// Every setting of the texel renderer that trades speed for error, each tried alone at 1 spp
/// on the default texels, so its cost and gain can be read off against the defaults.
const SETTINGS: [(&str, &str); 13] = [
    ("--step", "0.5"),
    ("--step", "2"),
    ("--cutoff", "0.01"),
    ("--cutoff", "0.0001"),
    ("--shadow-share", "0"),
    ("--shadow-share", "0.05"),
    ("--shadow-share", "0.5"),
    ("--view-share", "0"),
    ("--view-share", "0.2"),
    ("--lod-bias", "-1"),
    ("--lod-bias", "1"),
    ("--shadow-lod", "1"),
    ("--shadow-lod", "2"),
];

/// The hybrid method's settings, each tried alone at 1 and 4 spp against its defaults.
const HYBRID_SETTINGS: [(&str, &str); 5] = [
    ("--lod-switch", "0.5"),
    ("--lod-switch", "2"),
    ("--lod-switch", "4"),
    ("--lod-band", "0"),
    ("--lod-band", "2"),
];

/// Timed renders shorter than this (seconds) are repeated, and their median taken.
const REPEAT_BELOW: f64 = 5.0;
const REPEATS: usize = 3;

/// Views of the camera sweep from the far view to the near one, and the spp of their mesh
/// references.
const SWEEP_VIEWS: usize = 8;
const SWEEP_REFERENCE_SPP: u32 = 64;

/// One measured render.
struct Row {
    view: &'static str,
    method: String,
    setting: String,
    spp: u32,
    seconds: f64,
    rmse: f64,
    relative_mse: f64,
    alpha_rmse: f64,
    /// The image's pixels, digested ([`Measure::image`]): renders that make the same image
    /// are marked so, and the difference of their times read as what it is.
    image: String,
}

/// A render to time: its forest, and its flags besides the view's and the image size.
struct Job {
    forest: String,
    flags: Vec<String>,
}

struct Report {
    root: PathBuf,
    texel: PathBuf,
    work: PathBuf,
}

impl Report {
    /// Runs texel with `args` in the work directory, and returns what it printed.
    fn output(&self, args: &[&str]) -> Vec<u8> {
        let o = Command::new(&self.texel)
            .args(args)
            .current_dir(&self.work)
            .output()
            .expect("texel runs");
        assert!(
            o.status.success(),
            "texel {}: {}",
            args.join(" "),
            String::from_utf8_lossy(&o.stderr)
        );
        o.stdout
    }

    /// Runs texel with `args` in the work directory, and returns its wall time.
    fn run(&self, args: &[&str]) -> f64 {
        let start = Instant::now();
        self.output(args);
        start.elapsed().as_secs_f64()
    }

    /// Texels of one density model and resolution, and the forest placed with them (the same
    /// trees at the same places for every variant: placement does not depend on the texture).
    fn variant(&self, density: &str, resolution: u32) -> String {
        let dir = format!("{density}-{resolution}");
        std::fs::create_dir_all(self.work.join(&dir).join("trees")).unwrap();
        std::fs::copy(
            self.root.join("fixtures/species/forest.json"),
            self.work.join(&dir).join("species.json"),
        )
        .unwrap();
        for (name, file) in TREES {
            let model = self.root.join("fixtures/trees").join(file);
            self.run(&[
                "bake",
                model.to_str().unwrap(),
                "-o",
                &format!("{dir}/trees/{name}.texel"),
                "--resolution",
                &resolution.to_string(),
                "--fine",
                &(resolution * 4).max(256).to_string(),
                "--density",
                density,
                "-q",
            ]);
        }
        let terrain = self.root.join("fixtures/terrain/mountain.glb");
        self.run(&[
            "place",
            terrain.to_str().unwrap(),
            "--species",
            &format!("{dir}/species.json"),
            "-o",
            &format!("{dir}/forest.instances"),
            "--seed",
            "1",
            "-q",
        ]);
        format!("{dir}/forest.instances")
    }

    /// Renders `forest` from `view` with `extra` flags to `out`; returns the seconds taken.
    fn render(&self, forest: &str, view: &View<'_>, extra: &[&str], out: &str) -> f64 {
        let (w, h) = (WIDTH.to_string(), HEIGHT.to_string());
        let mut args = vec![
            "render", forest, "-o", out, "--width", &w, "--height", &h, "-q",
        ];
        args.extend_from_slice(view.flags);
        args.extend_from_slice(extra);
        self.run(&args)
    }

    /// Every job of `jobs` rendered from `view` to `out` and timed: each once, in order,
    /// `after()` called right after each run while `out` holds its image; then those
    /// shorter than [`REPEAT_BELOW`] again, in rounds over the whole list, until each has
    /// [`REPEATS`] runs. Each job's median time.
    ///
    /// In rounds, not back to back: this machine's speed drifts by up to a fifth over minutes
    /// (two runs of one image, minutes apart, read 1.04 s and 1.23 s in one report), and the
    /// report's ratios compare jobs with each other. Run back to back, a drift moved one job's
    /// three runs together; in rounds, it moves every job's alike.
    fn timed(&self, view: &View<'_>, jobs: &[Job], out: &str, mut after: impl FnMut()) -> Vec<f64> {
        let run = |job: &Job| {
            let flags: Vec<&str> = job.flags.iter().map(String::as_str).collect();
            self.render(&job.forest, view, &flags, out)
        };
        let mut times: Vec<Vec<f64>> = Vec::with_capacity(jobs.len());
        for job in jobs {
            times.push(vec![run(job)]);
            after();
        }
        for _ in 1..REPEATS {
            for (job, t) in jobs.iter().zip(&mut times) {
                if t[0] < REPEAT_BELOW {
                    t.push(run(job));
                }
            }
        }
        times
            .into_iter()
            .map(|mut t| {
                t.sort_by(f64::total_cmp);
                t[t.len() / 2]
            })
            .collect()
    }

    /// The ground truth for `view`: a mesh render at many spp with its canopy AOV, and `extra`
    /// flags (`--no-shadows` for the error budget), reused while the forest, the models and
    /// the mesh renderer's sources are unchanged.
    fn reference(&self, forest: &str, view: &View<'_>, extra: &[&str]) -> PathBuf {
        self.reference_at(forest, view, extra, REFERENCE_SPP)
    }

    /// [`Report::reference`] at `spp` samples per pixel.
    fn reference_at(&self, forest: &str, view: &View<'_>, extra: &[&str], spp: u32) -> PathBuf {
        let mut key = Sha256::new();
        // The trees' places, not the file: it also records the textures' hashes, and a
        // re-baked texture changes nothing the mesh method draws.
        let bytes = std::fs::read(self.work.join(forest)).unwrap();
        let placed = texel_forest::formats::instances::decode(&bytes).unwrap();
        key.update(format!("{:?}", placed.instances));
        for (_, file) in TREES {
            key.update(std::fs::read(self.root.join("fixtures/trees").join(file)).unwrap());
        }
        key.update(std::fs::read(self.root.join("fixtures/species/forest.json")).unwrap());
        for src in [
            "src/render/mesh.rs",
            "src/render/scene.rs",
            "src/render/camera.rs",
            "src/render/mod.rs",
            "src/render/instances.rs",
            "src/render/shading.rs",
            "src/mesh_tracer.rs",
            "src/geom/bvh.rs",
            "src/geom/offset.rs",
            "src/geom/triangle.rs",
        ] {
            key.update(std::fs::read(self.root.join(src)).unwrap());
        }
        key.update(format!("{:?} {extra:?} {WIDTH} {HEIGHT} {spp}", view.flags));
        let key = hex(&key.finalize()[..8]);
        let cache = self.root.join("report/cache");
        std::fs::create_dir_all(&cache).unwrap();
        let path = cache.join(format!("{}-{key}.exr", view.name));
        if !path.exists() {
            eprintln!(
                "report: reference for the {} view ({spp} spp mesh {})...",
                view.name,
                extra.join(" ")
            );
            let tmp = cache.join(format!("{}-{key}.tmp.exr", view.name));
            let spp = spp.to_string();
            let mut flags = vec![
                "--method", "mesh", "--spp", &spp, "--seed", "7", "--aov", "canopy",
                // Unbiased: the ground truth is the pixels' means, not the midpoint rule's.
                "--jitter",
            ];
            flags.extend_from_slice(extra);
            let seconds = self.render(forest, view, &flags, tmp.to_str().unwrap());
            std::fs::rename(&tmp, &path).unwrap();
            eprintln!("report: reference took {seconds:.0} s");
        }
        path
    }

    /// Texels of both density models at 16, 32 and 64 cells, with their forests, as
    /// (density, resolution, forest).
    fn variants(&self) -> Vec<(&'static str, u32, String)> {
        let mut variants = Vec::new();
        for density in ["transmittance", "occupancy"] {
            for resolution in [16, 32, 64] {
                variants.push((density, resolution, self.variant(density, resolution)));
            }
        }
        variants
    }

    /// Every way of rendering `view`, each timed and measured against the view's ground truth:
    /// the mesh method's spp sweep, every texel variant, then the settings sweep.
    fn measure_view(
        &self,
        view: &View<'static>,
        variants: &[(&str, u32, String)],
        default_forest: &str,
        rows: &mut Vec<Row>,
    ) {
        let reference = Rgba::read(
            &self.reference(default_forest, view, &[]),
            &Default::default(),
        )
        .unwrap();
        eprintln!("report: the {} view...", view.name);
        let out = format!("{}.exr", view.name);
        // In the order the tables list them: the mesh method's spp sweep, every texel
        // variant, the texel settings, the hybrid and its settings; each (method, setting,
        // spp) in `labels`.
        let (mut labels, mut jobs): (Vec<(String, String, u32)>, Vec<Job>) = (vec![], vec![]);
        let mut add = |method: &str, setting: &str, spp: u32, forest: &str, flags: &[&str]| {
            let flags = flags.iter().map(|f| f.to_string()).collect();
            let forest = forest.to_string();
            labels.push((method.into(), setting.into(), spp));
            jobs.push(Job { forest, flags });
        };
        for spp in [1, 4, 16, 64] {
            let s = spp.to_string();
            add(
                "mesh",
                "",
                spp,
                default_forest,
                &["--method", "mesh", "--spp", &s],
            );
        }
        for (density, resolution, forest) in variants {
            let spps: &[u32] = if *density == "transmittance" && *resolution == 32 {
                &[1, 4, 16]
            } else {
                &[1, 4]
            };
            for &spp in spps {
                let s = spp.to_string();
                let method = format!("texel {density} {resolution}");
                add(
                    &method,
                    "",
                    spp,
                    forest,
                    &["--method", "texel", "--spp", &s],
                );
            }
        }
        for (flag, value) in SETTINGS {
            let setting = format!("{flag} {value}");
            let flags = ["--method", "texel", flag, value];
            add(
                "texel transmittance 32",
                &setting,
                1,
                default_forest,
                &flags,
            );
        }
        for spp in [1, 4, 16] {
            let s = spp.to_string();
            add(
                "hybrid",
                "",
                spp,
                default_forest,
                &["--method", "hybrid", "--spp", &s],
            );
        }
        // Each sample through a random point of its stratum instead of its centre (the
        // default since stop 37), for every method: what centring gains at equal time.
        for (method, spps, flags) in [
            ("mesh", &[1, 4, 16][..], ["--method", "mesh"]),
            ("texel transmittance 32", &[1, 4][..], ["--method", "texel"]),
            ("hybrid", &[1, 4][..], ["--method", "hybrid"]),
        ] {
            for &spp in spps {
                let s = spp.to_string();
                let mut flags = flags.to_vec();
                flags.extend(["--spp", &s, "--jitter"]);
                add(method, "--jitter", spp, default_forest, &flags);
            }
        }
        // Pixels at edges rendered again at four times the samples (`--edge-spp`), for
        // every method: what the silhouettes' share of the error buys at equal time.
        for (method, flags) in [
            ("mesh", ["--method", "mesh"]),
            ("texel transmittance 32", ["--method", "texel"]),
            ("hybrid", ["--method", "hybrid"]),
        ] {
            for spp in [1, 4] {
                let (s, edges) = (spp.to_string(), (4 * spp).to_string());
                let mut flags = flags.to_vec();
                flags.extend(["--spp", &s, "--edge-spp", &edges]);
                add(
                    method,
                    &format!("--edge-spp {edges}"),
                    spp,
                    default_forest,
                    &flags,
                );
            }
        }
        for (flag, value) in HYBRID_SETTINGS {
            for spp in [1, 4] {
                let s = spp.to_string();
                let flags = ["--method", "hybrid", "--spp", &s, flag, value];
                add(
                    "hybrid",
                    &format!("{flag} {value}"),
                    spp,
                    default_forest,
                    &flags,
                );
            }
        }
        let mut errors = Vec::with_capacity(jobs.len());
        let seconds = self.timed(view, &jobs, &out, || {
            errors.push(measure(&self.work.join(&out), &reference));
        });
        for (((method, setting, spp), seconds), m) in labels.into_iter().zip(seconds).zip(errors) {
            rows.push(Row {
                view: view.name,
                method,
                setting,
                spp,
                seconds,
                rmse: m.rmse,
                relative_mse: m.relative_mse,
                alpha_rmse: m.alpha_rmse,
                image: m.image,
            });
        }
    }

    /// The camera moved from the far view to the near one in `SWEEP_VIEWS` steps (the
    /// distance to the point looked at shrinking geometrically, that point and the direction
    /// moving linearly): per step, the hybrid method at 1 spp, and the pure methods at 1 spp
    /// beside it, against a mesh reference.
    fn sweep(&self, forest: &str) -> Vec<SweepRow> {
        eprintln!("report: far-to-near sweep...");
        self.render(forest, &VIEWS[0], &["--method", "texel"], "camera.exr");
        let [far_eye, far_forward, ..] = camera_of(&self.work.join("camera.exr"));
        let near_eye = glam::DVec3::new(-110.0, 420.0, 190.0);
        let near_target = glam::DVec3::new(0.0, 330.0, 40.0);
        let (near_distance, near_forward) = (
            (near_target - near_eye).length(),
            (near_target - near_eye).normalize(),
        );
        // The far camera frames the forest's region: it looks at about where the near one
        // does, from the distance between them.
        let far_distance = (near_target - far_eye).length();
        let far_target = far_eye + far_forward * far_distance;
        let mut rows = Vec::new();
        for k in 0..SWEEP_VIEWS {
            let u = k as f64 / (SWEEP_VIEWS - 1) as f64;
            let target = far_target.lerp(near_target, u);
            let forward = far_forward.lerp(near_forward, u).normalize();
            let distance = far_distance.powf(1.0 - u) * near_distance.powf(u);
            let eye = target - forward * distance;
            let fov = 35.0 + 5.0 * u;
            let (eye, target, fov) = (
                format!("--eye={},{},{}", eye.x, eye.y, eye.z),
                format!("{},{},{}", target.x, target.y, target.z),
                fov.to_string(),
            );
            let flags = [
                eye.as_str(),
                "--target",
                target.as_str(),
                "--fov",
                fov.as_str(),
            ];
            let name = format!("sweep{k}");
            let view = View {
                name: &name,
                flags: &flags,
            };
            let reference = self.reference_at(forest, &view, &[], SWEEP_REFERENCE_SPP);
            let reference = Rgba::read(&reference, &Default::default()).unwrap();
            let out = format!("{name}.exr");
            let jobs = ["hybrid", "texel", "mesh"].map(|method| Job {
                forest: forest.to_string(),
                flags: vec!["--method".into(), method.into()],
            });
            let mut errors = Vec::new();
            let seconds = self.timed(&view, &jobs, &out, || {
                errors.push(measure(&self.work.join(&out), &reference).rmse);
            });
            rows.push(SweepRow {
                distance,
                hybrid: (seconds[0], errors[0]),
                texel: (seconds[1], errors[1]),
                mesh: (seconds[2], errors[2]),
            });
        }
        rows
    }

    /// Flicker: the far view with the camera moved by a fraction of a pixel between frames, as
    /// (method, mean per-pixel standard deviation) for the mesh and texel methods.
    fn flicker(&self, default_forest: &str) -> Vec<(&'static str, f64)> {
        eprintln!("report: flicker...");
        let far = &VIEWS[0];
        self.render(default_forest, far, &["--method", "texel"], "camera.exr");
        let camera = camera_of(&self.work.join("camera.exr"));
        let mut flicker = Vec::new();
        for (method, extra) in [
            ("mesh 1 spp", vec!["--method", "mesh"]),
            ("mesh 4 spp", vec!["--method", "mesh", "--spp", "4"]),
            ("mesh 16 spp", vec!["--method", "mesh", "--spp", "16"]),
            ("texel 1 spp", vec!["--method", "texel"]),
            ("texel 4 spp", vec!["--method", "texel", "--spp", "4"]),
            ("mesh 1 spp, jittered", vec!["--method", "mesh", "--jitter"]),
            (
                "texel 1 spp, jittered",
                vec!["--method", "texel", "--jitter"],
            ),
        ] {
            let frames = self.jittered_frames(default_forest, camera, &extra);
            flicker.push((method, mean_deviation(&frames)));
        }
        flicker
    }

    /// `FLICKER_FRAMES` renders of the far view with `extra` flags, the camera shifted by a
    /// fixed sub-pixel pattern, the same for every method so their flicker compares.
    fn jittered_frames(
        &self,
        forest: &str,
        [eye, forward, right, up]: [glam::DVec3; 4],
        extra: &[&str],
    ) -> Vec<Rgba> {
        let far = &VIEWS[0];
        let distance = 1500.0;
        let pixel = 2.0 * distance * (35f64.to_radians() / 2.0).tan() / HEIGHT as f64;
        let mut frames = Vec::new();
        for k in 0..FLICKER_FRAMES {
            let (dx, dy) = ((k as f64 * 0.618_034) % 1.0, (k as f64 * 0.381_966) % 1.0);
            let shift = (right * (dx - 0.5) + up * (dy - 0.5)) * pixel;
            let (e, t) = (eye + shift, eye + forward * distance + shift);
            let eye_flag = format!("--eye={},{},{}", e.x, e.y, e.z);
            let target = format!("{},{},{}", t.x, t.y, t.z);
            let mut args = vec![
                eye_flag.as_str(),
                "--target",
                target.as_str(),
                "--fov",
                "35",
            ];
            args.extend_from_slice(extra);
            let out = format!("flicker-{k}.exr");
            self.render(forest, far, &args, &out);
            frames.push(Rgba::read(&self.work.join(&out), &Default::default()).unwrap());
        }
        frames
    }
}

/// One step of the far-to-near sweep: the eye's distance to the point it looks at, and each
/// method's (seconds, rmse) at 1 spp.
struct SweepRow {
    distance: f64,
    hybrid: (f64, f64),
    texel: (f64, f64),
    mesh: (f64, f64),
}

/// A render's error against its reference, and what its image is.
struct Measure {
    rmse: f64,
    relative_mse: f64,
    alpha_rmse: f64,
    /// The first 8 bytes of the SHA-256 of the RGBA pixels' bits, in hex: the pixels, not the
    /// file, whose header names the flags that made it.
    image: String,
}

fn measure(out: &Path, reference: &Rgba) -> Measure {
    let image = Rgba::read(out, &Default::default()).unwrap();
    let c = compare(&image, reference, |_| true);
    let mut digest = Sha256::new();
    for p in &image.pixels {
        for v in p {
            digest.update(v.to_bits().to_le_bytes());
        }
    }
    Measure {
        rmse: c.rgb.rmse,
        relative_mse: c.rgb.relative_mse,
        alpha_rmse: c.alpha.rmse,
        image: hex(&digest.finalize()[..8]),
    }
}

/// Log-log interpolation of a method's curve (the mesh's, or any whose error falls as time
/// grows) to its time at `error`; `None` outside its range.
fn mesh_time_at(mesh: &[(f64, f64)], error: f64) -> Option<f64> {
    // Points are (seconds, error) with error falling as time grows.
    mesh.windows(2).find_map(|w| {
        let ((t0, e0), (t1, e1)) = (w[0], w[1]);
        if (e1..=e0).contains(&error) && e0 > e1 {
            let f = (error.ln() - e0.ln()) / (e1.ln() - e0.ln());
            Some((t0.ln() + f * (t1.ln() - t0.ln())).exp())
        } else {
            None
        }
    })
}

/// The camera of a render, from its EXR: eye, forward, right and up (world), for jitter.
fn camera_of(path: &Path) -> [glam::DVec3; 4] {
    let image = exr::prelude::read_all_flat_layers_from_file(path).unwrap();
    let m = image.layer_data[0]
        .attributes
        .world_to_camera
        .expect("worldToCamera");
    // Row-vector convention, p_camera = p_world * M, stored row by row: read column by column,
    // the same numbers are M's transpose, the column-vector transform glam applies. (Reading
    // them as M itself put the eye at the world's origin, and the flicker frames with it.)
    let m = glam::DMat4::from_cols_array(&m.map(f64::from));
    let inv = m.inverse();
    let eye = inv.transform_point3(glam::DVec3::ZERO);
    let axis = |v: glam::DVec3| inv.transform_vector3(v).normalize();
    // The camera looks along its +z (`worldToNDC` divides by z).
    [
        eye,
        axis(glam::DVec3::Z),
        axis(glam::DVec3::X),
        axis(glam::DVec3::Y),
    ]
}

/// The mean over pixels and colour channels of the standard deviation across `frames`: how
/// much a still picture shimmers as the camera moves by less than a pixel.
fn mean_deviation(frames: &[Rgba]) -> f64 {
    let n = frames.len() as f64;
    let pixels = frames[0].pixels.len();
    let mut sum = 0.0;
    for i in 0..pixels {
        for c in 0..3 {
            let v: Vec<f64> = frames.iter().map(|f| f64::from(f.pixels[i][c])).collect();
            let mean = v.iter().sum::<f64>() / n;
            let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
            sum += var.sqrt();
        }
    }
    sum / (3 * pixels) as f64
}

fn main() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let texel = root.join("target/release/texel");
    assert!(
        texel.exists(),
        "build the binary first (make report does: cargo build --release)"
    );
    let report = Report {
        work: root.join("report/work"),
        texel,
        root: root.clone(),
    };
    std::fs::create_dir_all(&report.work).unwrap();
    let started = Instant::now();
    // `make budget`: the error budget alone, for iterating on the method's accuracy.
    if std::env::args().any(|a| a == "--budget") {
        let forest = report.variant("transmittance", 32);
        print!("{}", budget::run(&report, &forest, &root.join("report")));
        return;
    }
    // `make flicker`: the fly-in's flicker alone.
    if std::env::args().any(|a| a == "--flicker") {
        let forest = report.variant("transmittance", 32);
        print!("{}", flyin::run(&report, &forest, &root.join("report")).1);
        return;
    }

    eprintln!("report: baking and placing the variants...");
    let variants = report.variants();
    let default_forest = variants
        .iter()
        .find(|v| v.0 == "transmittance" && v.1 == 32)
        .unwrap()
        .2
        .clone();

    let mut rows: Vec<Row> = Vec::new();
    for view in &VIEWS {
        report.measure_view(view, &variants, &default_forest, &mut rows);
    }
    let flicker = report.flicker(&default_forest);
    let sweep = report.sweep(&default_forest);
    let (_, flyin) = flyin::run(&report, &default_forest, &root.join("report"));
    let budget = budget::run(&report, &default_forest, &root.join("report"));

    write_outputs(
        &root.join("report"),
        &Measured {
            rows: &rows,
            flicker: &flicker,
            sweep: &sweep,
            budget: &budget,
            flyin: &flyin,
        },
        started.elapsed().as_secs_f64(),
    );
}

/// Everything the report measured.
struct Measured<'a> {
    rows: &'a [Row],
    flicker: &'a [(&'a str, f64)],
    sweep: &'a [SweepRow],
    budget: &'a str,
    /// The fly-in's flicker section (`flyin`).
    flyin: &'a str,
}

fn write_outputs(dir: &Path, m: &Measured, seconds: f64) {
    let Measured {
        rows,
        flicker,
        sweep,
        budget,
        flyin,
    } = *m;
    write_csv(dir, rows);
    let mut md = format!(
        "# Speed against error\n\nWritten by `make report` ({seconds:.0} s). Images {WIDTH} x {HEIGHT}; \
         error is the colour RMSE against a {REFERENCE_SPP}-spp mesh render (the ground truth); \
         times are whole `texel render` runs on this machine: runs under {REPEAT_BELOW} s are made \
         {REPEATS} times, in rounds over all of a view's renders (so that the machine's drift over \
         minutes moves them alike), and their median is taken. Renders whose pixels are \
         identical are marked so in the views' tables (`image`); where the hybrid draws every \
         tree from its texture it is the texel method, the same work, and its times differ from \
         the texel method's only by the run's noise.\n\n"
    );
    md += "## Headline\n\n| view | best texel setting | its time, error | mesh time for that error | texel faster by | texel error floor |\n|---|---|---|---|---|---|\n";
    for view in VIEWS.iter().map(|v| v.name) {
        write_headline(&mut md, view, rows);
    }
    md += "\n## The hybrid method at equal error\n\nHow much faster the hybrid method (default \
           switch and band) is than each pure method at its own error: the pure method's time \
           at that error, interpolated log-log along its spp curve (the texel method's: \
           transmittance, 32 cells), over the hybrid's; a dash where the pure method's curve \
           does not reach that error.\n\n| view | hybrid | its time, error | mesh time | faster than mesh | texel time | faster than texel |\n|---|---|---|---|---|---|---|\n";
    for view in VIEWS.iter().map(|v| v.name) {
        write_hybrid_ratios(&mut md, view, rows);
    }
    md += "\n## The hybrid's settings at equal error\n\nEach setting of `--lod-switch` and \
           `--lod-band` tried alone, against the defaults (switch 1 cell, band 1 octave): the \
           default's time at the setting's error, interpolated log-log along the default's spp \
           curve, over the setting's time. Above 1 the setting is faster at equal error; a dash \
           where the default's curve does not reach that error.\n\n| view | setting | spp | its \
           time, error | default's time | setting faster by |\n|---|---|---|---|---|---|\n";
    for view in VIEWS.iter().map(|v| v.name) {
        write_hybrid_settings(&mut md, view, rows);
    }
    write_hybrid_settings_summary(&mut md, rows);
    md += "\n";
    write_sweep(&mut md, dir, sweep);
    md += "\n";
    md += budget;
    md += "\n## Flicker (far view, camera moved by sub-pixel steps over ";
    md += &format!(
        "{FLICKER_FRAMES} frames; mean per-pixel standard deviation)\n\n| method | flicker |\n|---|---|\n"
    );
    for (m, f) in flicker {
        writeln!(md, "| {m} | {f:.5} |").unwrap();
    }
    md += flyin;
    for view in VIEWS.iter().map(|v| v.name) {
        write_view_section(&mut md, dir, view, rows);
    }
    std::fs::write(dir.join("README.md"), &md).unwrap();
    print!("{md}");
}

/// Every measured render, one row each, for anyone who wants to plot or compare them.
fn write_csv(dir: &Path, rows: &[Row]) {
    let mut csv =
        String::from("view,method,setting,spp,seconds,rmse,relative_mse,alpha_rmse,image\n");
    for r in rows {
        writeln!(
            csv,
            "{},{},{},{},{:.3},{:.6},{:.6},{:.6},{}",
            r.view,
            r.method,
            r.setting,
            r.spp,
            r.seconds,
            r.rmse,
            r.relative_mse,
            r.alpha_rmse,
            r.image
        )
        .unwrap();
    }
    std::fs::write(dir.join("speed_vs_error.csv"), csv).unwrap();
}

/// `method`'s curve in `view` with its default settings: (seconds, error) at each spp, the
/// rows with a setting (`--jitter`, `--step 2`, ...) left out.
fn curve(rows: &[Row], view: &str, method: &str) -> Vec<(f64, f64)> {
    rows.iter()
        .filter(|r| r.view == view && r.method == method && r.setting.is_empty())
        .map(|r| (r.seconds, r.rmse))
        .collect()
}

/// Per default hybrid render of `view`: its time and error, and each pure method's time at
/// that error.
fn write_hybrid_ratios(md: &mut String, view: &str, rows: &[Row]) {
    let (mesh, texel) = (
        curve(rows, view, "mesh"),
        curve(rows, view, "texel transmittance 32"),
    );
    for r in rows
        .iter()
        .filter(|r| r.view == view && r.method == "hybrid" && r.setting.is_empty())
    {
        let at = |c: &[(f64, f64)]| match mesh_time_at(c, r.rmse) {
            Some(t) => (format!("{t:.2} s"), format!("{:.2}x", t / r.seconds)),
            None => ("-".into(), "-".into()),
        };
        let ((mt, mx), (tt, mut tx)) = (at(&mesh), at(&texel));
        // In a view where no tree is near enough to be a model the hybrid is the texel method
        // (`Draw::simplified`): the same image by the same work, whose times differ only by
        // the run's noise. Said so, not read as a speed-up or a loss.
        let texel_twin = rows.iter().find(|t| {
            t.view == view
                && t.method == "texel transmittance 32"
                && t.setting.is_empty()
                && t.spp == r.spp
                && t.image == r.image
        });
        if let Some(t) = texel_twin {
            tx = format!(
                "the same image: {:.2}x measured, {:.2} s against {:.2} s",
                t.seconds / r.seconds,
                t.seconds,
                r.seconds
            );
        }
        writeln!(
            md,
            "| {view} | {} spp | {:.2} s, {:.4} | {mt} | {mx} | {tt} | {tx} |",
            r.spp, r.seconds, r.rmse
        )
        .unwrap();
    }
}

/// Per hybrid setting rendered in `view`: its time and error, and the default hybrid's time
/// at that error.
fn write_hybrid_settings(md: &mut String, view: &str, rows: &[Row]) {
    for (r, default, ratio) in hybrid_settings(view, rows) {
        let (d, x) = match (default, ratio) {
            (Some(d), Some(x)) => (format!("{d:.2} s"), format!("{x:.2}x")),
            _ => ("-".into(), "-".into()),
        };
        writeln!(
            md,
            "| {view} | {} | {} | {:.2} s, {:.4} | {d} | {x} |",
            r.setting, r.spp, r.seconds, r.rmse
        )
        .unwrap();
    }
}

/// Each hybrid setting row of `view`, with the default hybrid's time at its error and that
/// time over the setting's.
fn hybrid_settings<'r>(view: &str, rows: &'r [Row]) -> Vec<(&'r Row, Option<f64>, Option<f64>)> {
    let default = curve(rows, view, "hybrid");
    rows.iter()
        .filter(|r| r.view == view && r.method == "hybrid" && !r.setting.is_empty())
        .map(|r| {
            let d = mesh_time_at(&default, r.rmse);
            (r, d, d.map(|d| d / r.seconds))
        })
        .collect()
}

/// Per setting, the geometric mean over the views and spp of how much faster it is than the
/// default at equal error: the figure the defaults are chosen by.
fn write_hybrid_settings_summary(md: &mut String, rows: &[Row]) {
    let mut settings: Vec<(String, Vec<f64>, usize)> = Vec::new();
    for view in VIEWS.iter().map(|v| v.name) {
        for (r, _, ratio) in hybrid_settings(view, rows) {
            let i = match settings.iter().position(|s| s.0 == r.setting) {
                Some(i) => i,
                None => {
                    settings.push((r.setting.clone(), Vec::new(), 0));
                    settings.len() - 1
                }
            };
            settings[i].2 += 1;
            settings[i].1.extend(ratio);
        }
    }
    *md += "\n| setting | geometric mean, faster than the default at equal error | points compared |\n|---|---|---|\n";
    for (setting, ratios, points) in settings {
        let mean = if ratios.is_empty() {
            "-".to_string()
        } else {
            let log = ratios.iter().map(|x| x.ln()).sum::<f64>() / ratios.len() as f64;
            format!("{:.2}x", log.exp())
        };
        writeln!(md, "| {setting} | {mean} | {} of {points} |", ratios.len()).unwrap();
    }
}

/// The far-to-near sweep: a table per step and a plot of error and time against distance.
fn write_sweep(md: &mut String, dir: &Path, sweep: &[SweepRow]) {
    writeln!(
        md,
        "## Far to near\n\nThe camera moved from the far view to the near one in {SWEEP_VIEWS} steps, \
         each method at 1 spp against a {SWEEP_REFERENCE_SPP}-spp mesh render of the step.\n\n\
         ![](sweep.png)\n\n| step | distance m | hybrid s, rmse | texel s, rmse | mesh s, rmse |\n|---|---|---|---|---|"
    )
    .unwrap();
    for (k, s) in sweep.iter().enumerate() {
        let f = |(t, e): (f64, f64)| format!("{t:.2}, {e:.4}");
        writeln!(
            md,
            "| {k} | {:.0} | {} | {} | {} |",
            s.distance,
            f(s.hybrid),
            f(s.texel),
            f(s.mesh)
        )
        .unwrap();
    }
    let series =
        |name: &str, k: usize, pick: &dyn Fn(&SweepRow) -> (f64, f64), time: bool| Series {
            name: format!("{name} {}", if time { "seconds / 100" } else { "rmse" }),
            color: PALETTE[k % PALETTE.len()],
            points: sweep
                .iter()
                .map(|s| {
                    let (t, e) = pick(s);
                    (s.distance, if time { t / 100.0 } else { e })
                })
                .collect(),
        };
    let plot = Plot {
        title: "far to near, 1 spp: error and time against distance".into(),
        x_label: "distance to the point looked at (m)".into(),
        y_label: "rmse, seconds / 100".into(),
        series: vec![
            series("hybrid", 0, &|s| s.hybrid, false),
            series("texel", 1, &|s| s.texel, false),
            series("mesh", 2, &|s| s.mesh, false),
            series("hybrid", 3, &|s| s.hybrid, true),
            series("texel", 4, &|s| s.texel, true),
            series("mesh", 5, &|s| s.mesh, true),
        ],
    };
    plot.draw(900, 560).save(dir.join("sweep.png")).unwrap();
}

/// A render's method, setting and spp, as the headline names it.
fn row_label(r: &Row) -> String {
    format!(
        "{}{}{}",
        r.method,
        if r.setting.is_empty() { "" } else { ", " },
        r.setting
    ) + &format!(", {} spp", r.spp)
}

/// The first other render of `r`'s view that made the same image, if any: the same pixels from
/// other flags (a setting that changes nothing in this view, or the hybrid drawing every tree
/// from its texture), whose difference in time is only the run's noise.
fn same_image<'r>(rows: &'r [Row], r: &Row) -> Option<&'r Row> {
    rows.iter()
        .find(|o| o.view == r.view && o.image == r.image && !std::ptr::eq(*o, r))
}

/// " (the same image as ...)" where [`same_image`] finds one, else nothing.
fn same_image_note(rows: &[Row], r: &Row) -> String {
    same_image(rows, r).map_or(String::new(), |o| {
        format!(" (the same image as {})", row_label(o))
    })
}

/// The headline's row for `view`: the paper's claim, how much faster the texel method is than
/// the mesh at equal error, and the error the texel method cannot get below.
fn write_headline(md: &mut String, view: &str, rows: &[Row]) {
    let mesh = curve(rows, view, "mesh");
    let texels: Vec<&Row> = rows
        .iter()
        .filter(|r| r.view == view && r.method.starts_with("texel"))
        .collect();
    let floor = texels
        .iter()
        .min_by(|a, b| a.rmse.total_cmp(&b.rmse))
        .unwrap();
    // The texel setting with the largest speed-up over the mesh at equal error, where the
    // mesh curve reaches that error; else the fastest texel render.
    let best = texels
        .iter()
        .filter_map(|r| mesh_time_at(&mesh, r.rmse).map(|m| (r, m, m / r.seconds)))
        .max_by(|a, b| a.2.total_cmp(&b.2));
    let floor_text = format!("{:.4} ({})", floor.rmse, row_label(floor));
    match best {
        Some((r, m, x)) => writeln!(
            md,
            "| {view} | {}{} | {:.2} s, {:.4} | {m:.2} s | {x:.2}x | {floor_text} |",
            row_label(r),
            same_image_note(rows, r),
            r.seconds,
            r.rmse
        ),
        None => {
            let (t1, e1) = mesh[0];
            let fastest = texels
                .iter()
                .min_by(|a, b| a.seconds.total_cmp(&b.seconds))
                .unwrap();
            writeln!(
                md,
                "| {view} | {} | {:.2} s, {:.4} | mesh at 1 spp: {t1:.2} s, {e1:.4} | no texel setting falls within the mesh curve | {floor_text} |",
                row_label(fastest),
                fastest.seconds,
                fastest.rmse
            )
        }
    }
    .unwrap();
}

/// The section for `view`: every row in a table, and the plot of error against time written
/// beside the README, which the section links.
fn write_view_section(md: &mut String, dir: &Path, view: &str, rows: &[Row]) {
    writeln!(
        md,
        "\n## {view} view\n\n![](speed_vs_error_{view}.png)\n\n| method | setting | spp | seconds | rmse | rel. mse | alpha rmse | image |\n|---|---|---|---|---|---|---|---|"
    )
    .unwrap();
    for r in rows.iter().filter(|r| r.view == view) {
        let image = match same_image(rows, r) {
            Some(first) => format!("the same as {}", row_label(first)),
            None => String::new(),
        };
        writeln!(
            md,
            "| {} | {} | {} | {:.2} | {:.5} | {:.5} | {:.5} | {image} |",
            r.method, r.setting, r.spp, r.seconds, r.rmse, r.relative_mse, r.alpha_rmse
        )
        .unwrap();
    }
    speed_vs_error_plot(view, rows)
        .draw(900, 560)
        .save(dir.join(format!("speed_vs_error_{view}.png")))
        .unwrap();
}

/// Error against time for `view`, one curve per method: the settings sweep is in the table,
/// not the plot, where its single points would crowd the curves.
fn speed_vs_error_plot(view: &str, rows: &[Row]) -> Plot {
    let mut methods: Vec<&str> = Vec::new();
    for r in rows
        .iter()
        .filter(|r| r.view == view && r.setting.is_empty())
    {
        if !methods.contains(&r.method.as_str()) {
            methods.push(&r.method);
        }
    }
    Plot {
        title: format!("{view} view: error against time"),
        x_label: "seconds".into(),
        y_label: "rmse".into(),
        series: methods
            .iter()
            .enumerate()
            .map(|(k, m)| Series {
                name: m.to_string(),
                color: PALETTE[k % PALETTE.len()],
                points: curve(rows, view, m),
            })
            .collect(),
    }
}
