//! `texel render`: forest + texels + terrain -> OpenEXR (and a preview).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::bail;
use glam::{DVec3, Vec3};

use texel_forest::import;
use texel_forest::limits::{Limits, check_memory};
use texel_forest::output::{Outputs, depfile_for};
use texel_forest::render::camera_path::CameraPath;
use texel_forest::render::load::{self, LoadedScene, Meshes, SceneRequest};
use texel_forest::render::{
    self, Aovs, Camera, Film, Lighting, Lod, March, MatteNames, Method, RenderSettings, Shading,
    ShadowRays,
    view::{self, CameraChoice},
};
use texel_forest::rng;

use crate::cli::{AovArg, MethodArg, RenderArgs, ShadowsArg};

/// Where a run's camera comes from.
enum Aim<'a> {
    /// A camera path, and the file it was read from.
    Path(&'a CameraPath, &'a Path),
    Still(Camera),
}

/// One image a run renders: a still, or one frame of a sequence.
struct Shot {
    /// The frame number, for a sequence.
    frame: Option<u32>,
    exr: PathBuf,
    preview: Option<PathBuf>,
}

pub fn run(args: &RenderArgs, limits: &Limits, quiet: bool) -> anyhow::Result<()> {
    let start = Instant::now();
    // The recorded terrain is converted as the forest recorded it; the flags are for --terrain.
    if args.terrain.is_none() && !args.heightmap.options().is_empty() {
        anyhow::bail!(
            "--terrain-size and --height-range convert the heightmap --terrain names; {} \
             records how its own terrain was converted",
            args.instances.display()
        );
    }
    if let Some(edge_spp) = args.edge_spp
        && edge_spp != 0
        && edge_spp <= args.spp
    {
        anyhow::bail!(
            "--edge-spp {edge_spp} would render edges again with no more samples than --spp {} \
             gave them; give more, or 0 for none",
            args.spp
        );
    }
    let path = args
        .camera_path
        .as_ref()
        .map(|file| {
            CameraPath::load(file, args.camera.as_deref(), limits)
                .map(|(path, files)| (path, files, file.as_path()))
        })
        .transpose()?;
    if let Some((CameraPath::Gltf(a), ..)) = &path {
        for w in &a.warnings {
            super::warn(w);
        }
    }
    let shots = shots(args, path.as_ref().map(|(p, ..)| p))?;
    let mut planned = plan(args, limits, &shots)?;
    let mut loaded = load::load(&SceneRequest {
        forest: &args.instances,
        terrain: args.terrain.as_deref(),
        heightmap: args.heightmap.options(),
        day: args.day,
        meshes: match args.method {
            Some(MethodArg::Texel) => Meshes::Skip,
            Some(MethodArg::Mesh | MethodArg::Hybrid) => Meshes::Require,
            None => Meshes::Prefer,
        },
        limits: *limits,
    })?;
    if let Some(t) = &args.terrain
        && let Some(why) = loaded.terrain_mismatch()
    {
        super::warn(&format!(
            "--terrain {}: {why}: it is not the ground the forest was placed on, so trees will \
             float or be buried",
            t.display()
        ));
    }
    let mut method = args
        .method
        .unwrap_or_else(|| match loaded.without_meshes.take() {
            None => MethodArg::Hybrid,
            Some(why) => {
                warn_textures_only(args, "", why);
                MethodArg::Texel
            }
        });
    let mut dependencies = loaded.dependencies.clone();
    planned.add_inputs(&dependencies)?;
    let views = match &args.camera_file {
        Some(p) => {
            dependencies.push(p.clone());
            import::load_with(p, limits)?
        }
        None => loaded.terrain.clone(),
    };
    if let Some((_, files, _)) = &path {
        dependencies.extend(files.iter().cloned());
    }
    // The depfile is written with the last frame; a name it cannot hold is refused before
    // the first is rendered.
    let depfile_rule = match &args.depfile {
        Some(_) => {
            let targets: Vec<&Path> = shots.iter().map(|s| s.exr.as_path()).collect();
            Some(depfile_for(&targets, &dependencies)?)
        }
        None => None,
    };
    // Where the camera comes from: the path, frame by frame, or the flags, once.
    let aim = match &path {
        Some((p, _, file)) => Aim::Path(p, file),
        None => Aim::Still(camera(args, &loaded, &views)?),
    };
    let lighting = Lighting {
        sun: view::sun(args.sun, &views.suns),
        shading: Shading::default(),
        sky: args.sky.map(|s| DVec3::from(s).as_vec3()),
    };
    let size = (args.width, args.height);
    let species: Vec<String> = loaded
        .forest
        .info
        .species
        .iter()
        .map(|s| s.name.clone())
        .collect();
    let sequence = shots.len() > 1 || shots[0].frame.is_some();
    // Checked with the scene, read by the first frame that draws a tree from its model.
    let mut models = loaded.models.take();
    let mut loaded = Some(loaded);
    // The sun-depth grids do not depend on the eye: built once for the whole sequence.
    let mut grids = None;
    // Every frame's camera before the first frame renders: a path that fails in its middle
    // fails before writing the frames ahead of the failure.
    let cameras = shots
        .iter()
        .map(|shot| match &aim {
            Aim::Path(p, file) => {
                let time = f64::from(shot.frame.unwrap_or(0)) / args.fps;
                p.camera(time, args.fov, view::DEFAULT_FOV, size)
                    .map_err(|e| {
                        anyhow::anyhow!(
                            "frame {}: {}: {e}",
                            shot.frame.unwrap_or(0),
                            file.display()
                        )
                    })
            }
            Aim::Still(c) => Ok(*c),
        })
        .collect::<anyhow::Result<Vec<Camera>>>()?;
    for (n, (shot, camera)) in shots.iter().zip(cameras).enumerate() {
        if let (Aim::Path(..), Some(l)) = (&aim, &loaded) {
            warn_underground(l, &camera);
        }
        let build_start = Instant::now();
        // The last shot may take what was loaded; earlier ones build from a copy, each frame's
        // scene being in the frame of its own eye.
        let mut scene = if n + 1 == shots.len() {
            loaded
                .take()
                .map(|l| l.into_scene(camera.eye, lighting))
                .ok_or_else(|| anyhow::anyhow!("the scene was already used"))?
        } else {
            loaded
                .as_ref()
                .map(|l| l.scene(camera.eye, lighting))
                .ok_or_else(|| anyhow::anyhow!("the scene was already used"))?
        };
        if let Some(grids) = grids.take() {
            scene.reuse_sun_depth(grids);
        }
        scene.shadows = !args.no_shadows;
        let frame_settings = |method| {
            let mut settings = settings(args, method);
            if let Some(f) = shot.frame {
                // Each frame its own noise, and the same whichever frames render with it; the
                // hybrid's choice of drawing for each tree stays the sequence's.
                settings.seed = rng::hash3(args.seed, u64::from(f), rng::purpose::FRAME);
            }
            settings
        };
        let mut settings = frame_settings(method);
        if render::draws_models(&scene, &camera, &settings) {
            // The last shot takes the models; earlier ones draw from a copy.
            let meshes = if n + 1 == shots.len() {
                models.take().map(|m| m.into_meshes())
            } else {
                models.as_mut().map(|m| m.get().map(<[_]>::to_vec))
            };
            match meshes {
                Some(Ok(meshes)) => scene = scene.with_meshes(meshes),
                // The default method draws what there is: every tree from its texture, this
                // frame and the ones after it, as when the models fail their check.
                Some(Err(why)) if args.method.is_none() => {
                    warn_textures_only(args, " from here on", why);
                    models = None;
                    method = MethodArg::Texel;
                    settings = frame_settings(method);
                }
                Some(Err(why)) => return Err(why.into()),
                None => bail!("this frame draws trees from their models, which were not loaded"),
            }
        }
        let build = build_start.elapsed().as_secs_f64();
        let pixels = args.crop.map_or(
            u64::from(args.width) * u64::from(args.height),
            |[x0, y0, x1, y1]| u64::from(x1 - x0) * u64::from(y1 - y0),
        );
        let bar = progress_bar(pixels, quiet);
        let render_start = Instant::now();
        let film = render::render(&scene, &camera, &settings, &|n| bar.inc(n));
        bar.finish_and_clear();
        let seconds = render_start.elapsed().as_secs_f64();

        let depfile = (n + 1 == shots.len())
            .then_some(args.depfile.as_ref().zip(depfile_rule.as_ref()))
            .flatten()
            .map(|(d, rule)| (d.as_path(), rule.clone()));
        // Only Cryptomatte names objects: a name per tree is work a plain frame does not need.
        let names = settings
            .mattes
            .then(|| MatteNames::new(species.clone(), &scene));
        write(
            args,
            shot,
            &film,
            (&camera, names.as_ref()),
            &dependencies,
            depfile,
        )?;
        if !quiet {
            let what = if sequence {
                format!("frame {}: ", shot.frame.unwrap_or(0))
            } else {
                String::new()
            };
            summary(
                (args, method, settings.edges),
                &scene,
                &film,
                &shot.exr,
                (seconds, build),
                start,
                &what,
            );
        }
        // The next frame reads the grids this one built, and builds only those it adds.
        grids = Some(scene.sun_depth);
    }
    Ok(())
}

/// Warns that the default method draws every tree from its texture (`when`: from which frame
/// on, or "" for all) because the models could not be had.
fn warn_textures_only(args: &RenderArgs, when: &str, why: load::LoadError) {
    super::warn(&format!(
        "{}: every tree drawn from its texture{when} (the hybrid method, the default, needs the models the textures were baked from): {:#}; --method texel asks for this without the warning",
        args.instances.display(),
        anyhow::Error::from(why)
    ));
}

/// The images to render: one still, or the frames of `--frames` (else every frame of the
/// camera path at `--fps`), each with its file names.
fn shots(args: &RenderArgs, path: Option<&CameraPath>) -> anyhow::Result<Vec<Shot>> {
    let frames = match (args.frames, path) {
        (Some((a, b)), _) => a..=b,
        (None, Some(p)) => {
            let (first, last) = p.span();
            let (a, b) = ((first * args.fps).ceil(), (last * args.fps).floor());
            if a < 0.0 {
                bail!(
                    "--camera-path {}: starts at {first} s, before time 0; give --frames",
                    args.camera_path
                        .as_deref()
                        .unwrap_or(Path::new(""))
                        .display()
                );
            }
            if b - a >= f64::from(crate::cli::MAX_FRAMES) {
                bail!(
                    "--camera-path {}: more than {} frames at {} fps; give --frames",
                    args.camera_path
                        .as_deref()
                        .unwrap_or(Path::new(""))
                        .display(),
                    crate::cli::MAX_FRAMES,
                    args.fps
                );
            }
            // A path shorter than a frame is one frame, at its start.
            (a as u32)..=(b.max(a) as u32)
        }
        (None, None) => {
            return Ok(vec![Shot {
                frame: None,
                exr: args.output.clone(),
                preview: args.preview.clone(),
            }]);
        }
    };
    let count = (frames.end() - frames.start()) as usize + 1;
    frames
        .map(|f| {
            Ok(Shot {
                frame: Some(f),
                exr: numbered("-o", &args.output, f, count)?,
                preview: args
                    .preview
                    .as_ref()
                    .map(|p| numbered("--preview", p, f, count))
                    .transpose()?,
            })
        })
        .collect()
}

/// `path` with the last run of `#`s in its file name replaced by `frame`, zero-padded to
/// their count; a name without `#`s is kept for a sequence of one frame and refused for more.
fn numbered(flag: &str, path: &Path, frame: u32, count: usize) -> anyhow::Result<PathBuf> {
    let name = match path.file_name().map(|n| n.to_str()) {
        None => "",
        Some(Some(name)) => name,
        Some(None) if count == 1 => return Ok(path.to_path_buf()),
        Some(None) => bail!(
            "{flag} {}: the file name is not UTF-8, so no frame number can be put in it",
            path.display()
        ),
    };
    let Some(end) = name.rfind('#') else {
        if count == 1 {
            return Ok(path.to_path_buf());
        }
        bail!(
            "{flag} {}: a sequence of {count} frames needs #s in the file name where the frame number goes (e.g. frame.####.exr)",
            path.display()
        );
    };
    let begin = name[..end]
        .char_indices()
        .rev()
        .find(|&(_, c)| c != '#')
        .map_or(0, |(i, c)| i + c.len_utf8());
    let digits = end + 1 - begin;
    let file = format!("{}{frame:0digits$}{}", &name[..begin], &name[end + 1..]);
    Ok(path.with_file_name(file))
}

/// Checks the frame's size and every output of every shot, before anything is read: the
/// outputs planned (to check against the inputs found while loading; each shot commits its
/// own).
fn plan(args: &RenderArgs, limits: &Limits, shots: &[Shot]) -> anyhow::Result<Outputs> {
    let pixels = u64::from(args.width) * u64::from(args.height);
    limits.check_pixels(pixels, "--width x --height")?;
    if let Some([x0, y0, x1, y1]) = args.crop
        && !(x1 <= args.width && y1 <= args.height)
    {
        bail!(
            "--crop {x0},{y0},{x1},{y1} must lie within the {}x{} frame",
            args.width,
            args.height
        );
    }
    // The film holds the crop's pixels alone; edges sampled again add a mark per pixel and
    // the index of each one marked.
    let (held, what) = match args.crop {
        Some([x0, y0, x1, y1]) => (
            u64::from(x1 - x0) * u64::from(y1 - y0),
            format!(
                "--crop {x0},{y0},{x1},{y1}'s {}x{} pixels",
                x1 - x0,
                y1 - y0
            ),
        ),
        None => (
            pixels,
            format!(
                "a {}x{} frame (--width x --height)",
                args.width, args.height
            ),
        ),
    };
    let per_pixel = aovs(args).bytes_per_pixel() + if args.edge_spp == Some(0) { 0 } else { 5 };
    check_memory(
        held.saturating_mul(per_pixel),
        &format!("{what}, with the layers --aov asks for,"),
    )?;
    let mut outputs = Outputs::new(&inputs(args));
    for s in shots {
        outputs.add("-o", &s.exr)?;
        if let Some(p) = &s.preview {
            outputs.add("--preview", p)?;
        }
    }
    if let Some(d) = &args.depfile {
        outputs.add("--depfile", d)?;
    }
    Ok(outputs)
}

fn inputs(args: &RenderArgs) -> Vec<&Path> {
    let mut inputs = vec![args.instances.as_path()];
    inputs.extend(args.terrain.as_deref());
    inputs.extend(args.camera_file.as_deref());
    inputs.extend(args.camera_path.as_deref());
    inputs
}

/// The camera the flags ask for (the forest framed by default), with a warning when the eye
/// is under the terrain.
fn camera(args: &RenderArgs, scene: &LoadedScene, views: &import::Model) -> anyhow::Result<Camera> {
    let choice = match (args.eye, args.target, &args.camera) {
        (Some(eye), Some(target), _) => CameraChoice::LookAt { eye, target },
        (_, _, Some(name)) => CameraChoice::Named(name),
        _ => {
            let (lo, hi) = scene.forest_bounds();
            CameraChoice::Frame { lo, hi }
        }
    };
    let camera = view::camera(
        choice,
        args.fov,
        (args.width, args.height),
        &views.cameras,
        &views.orthographic,
    )
    .map_err(|e| anyhow::anyhow!(e))?;
    warn_underground(scene, &camera);
    Ok(camera)
}

/// Warns when the eye is under the terrain.
fn warn_underground(scene: &LoadedScene, camera: &Camera) {
    let e = camera.eye;
    if let Some(ground) = scene.ground_height(e.x, e.z)
        && e.y < ground
    {
        super::warn(&format!(
            "the eye ({:.1}, {:.1}, {:.1}) is {:.1} m below the terrain, whose surface is at {ground:.1} m there: the render shows the terrain's underside",
            e.x,
            e.y,
            e.z,
            ground - e.y
        ));
    }
}

/// The layers `--aov` asks for.
fn aovs(args: &RenderArgs) -> Aovs {
    Aovs {
        normal: args.aov.contains(&AovArg::Normal),
        albedo: args.aov.contains(&AovArg::Albedo),
        canopy: args.aov.contains(&AovArg::Canopy),
        species: args.aov.contains(&AovArg::Species),
        lod: args.aov.contains(&AovArg::Lod),
        samples: args.aov.contains(&AovArg::Samples),
        cryptomatte: args.aov.contains(&AovArg::Cryptomatte),
    }
}

fn settings(args: &RenderArgs, method: MethodArg) -> RenderSettings {
    let method = match method {
        MethodArg::Texel => Method::Texel,
        MethodArg::Mesh => Method::Mesh,
        MethodArg::Hybrid => Method::Hybrid,
    };
    RenderSettings {
        method,
        spp: args.spp,
        jitter: args.jitter,
        march: March {
            step: args.step,
            cutoff: args.cutoff,
            lod_bias: args.lod_bias,
            shadow_lod: args.shadow_lod,
            shadow_share: args.shadow_share,
            shadows: match args.shadows {
                ShadowsArg::Cached => ShadowRays::Cached,
                ShadowsArg::Exact => ShadowRays::Exact,
            },
            view_share: args.view_share,
        },
        lod: Lod {
            switch: args.lod_switch,
            band: args.lod_band,
        },
        crop: args.crop,
        seed: args.seed,
        lod_seed: args.seed,
        edges: match args.edge_spp {
            Some(0) => None,
            Some(spp) => Some(render::Edges {
                spp,
                contrast: args.edge_contrast as f32,
                colour: true,
            }),
            None => render::Edges::default_for(method, args.spp),
        },
        mattes: args.aov.contains(&AovArg::Cryptomatte),
        layers: aovs(args),
    }
}

fn progress_bar(pixels: u64, quiet: bool) -> indicatif::ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    indicatif::ProgressBar::new(pixels).with_style(
        indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {percent}% {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    )
}

/// Encodes a shot's EXR and preview (and the run's depfile, with the last shot), and commits
/// them together.
fn write(
    args: &RenderArgs,
    shot: &Shot,
    film: &Film,
    (camera, names): (&Camera, Option<&MatteNames>),
    dependencies: &[PathBuf],
    depfile: Option<(&Path, String)>,
) -> anyhow::Result<()> {
    let mut outputs = Outputs::new(&inputs(args));
    outputs.add_inputs(dependencies)?;
    let exr_id = outputs.add("-o", &shot.exr)?;
    let exr = film
        .exr_bytes(
            args.half,
            aovs(args),
            camera.world_to_camera(),
            camera.world_to_ndc(),
            names,
        )
        .map_err(|e| anyhow::anyhow!("{}: cannot encode: {e}", shot.exr.display()))?;
    if exr.clamped > 0 {
        super::warn(&format!(
            "{}: {} values above the half-float maximum (65504) were clamped to it; drop --half to keep them",
            shot.exr.display(),
            exr.clamped
        ));
    }
    outputs.set(exr_id, exr.bytes);
    if let Some(p) = &shot.preview {
        let id = outputs.add("--preview", p)?;
        let png = texel_forest::png::encode(&film.preview(Vec3::new(0.55, 0.68, 0.85)));
        outputs.set(id, png);
    }
    if let Some((path, rule)) = depfile {
        let id = outputs.add("--depfile", path)?;
        outputs.set(id, rule.into_bytes());
    }
    Ok(outputs.commit()?)
}

/// The run's summary line for one shot.
fn summary(
    (args, method, edges): (&RenderArgs, MethodArg, Option<render::Edges>),
    scene: &render::Scene,
    film: &Film,
    exr: &Path,
    (seconds, build): (f64, f64),
    start: Instant,
    what: &str,
) {
    let trees = scene.instances.len();
    let pixels = film.width as u64 * film.height as u64;
    let rays = pixels * u64::from(args.spp);
    let (samples, shadow_rays) = film.work();
    let (drawn_from, work) = match method {
        MethodArg::Texel => (
            "textures",
            format!("{samples:.1} volume samples and {shadow_rays:.1} shadow rays per pixel"),
        ),
        MethodArg::Mesh => ("meshes", format!("{shadow_rays:.1} shadow rays per pixel")),
        // A hybrid frame whose trees are all far enough to be textures read no model.
        MethodArg::Hybrid if scene.meshes.is_empty() => (
            "textures (hybrid: none near enough to be drawn from its model)",
            format!("{samples:.1} volume samples and {shadow_rays:.1} shadow rays per pixel"),
        ),
        MethodArg::Hybrid => (
            "meshes and textures",
            format!("{samples:.1} volume samples and {shadow_rays:.1} shadow rays per pixel"),
        ),
    };
    let (grids, bytes) = scene.sun_depth.built();
    let work = if grids > 0 {
        format!(
            "{work}, {grids} sun-depth grids ({:.1} MiB)",
            bytes as f64 / f64::from(1 << 20)
        )
    } else {
        work
    };
    let work = match edges {
        Some(e) => format!(
            "{work}, {} pixels at {} rendered again at {} spp",
            film.sampled_again,
            if e.colour { "edges" } else { "the outline" },
            e.spp
        ),
        None => work,
    };
    let memory = texel_forest::limits::peak_memory()
        .map_or(String::new(), |b| format!(", peak memory {} MiB", b >> 20));
    super::summary(&format!(
        "{what}rendered {trees} trees from their {drawn_from}, {}x{} ({pixels} pixels) at {} spp in {seconds:.2} s: {:.0} primary rays/s, {work} -> {} (scene built in {build:.2} s, {:.2} s in all{memory})",
        args.width,
        args.height,
        args.spp,
        rays as f64 / seconds,
        exr.display(),
        start.elapsed().as_secs_f64()
    ));
}
