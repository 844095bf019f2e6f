//! `texel render`: forest + texels + terrain -> OpenEXR (and a preview).

use std::io::IsTerminal;
use std::time::Instant;

use anyhow::bail;
use glam::{DVec3, Vec3};

use texel_forest::import;
use texel_forest::limits::{Limits, check_memory};
use texel_forest::output::{OutputId, Outputs, depfile};
use texel_forest::render::load::{self, LoadedScene, SceneRequest};
use texel_forest::render::{
    self, Aovs, Camera, Film, Lighting, Lod, March, Method, RenderSettings, Shading, ShadowRays,
    film,
    view::{self, CameraChoice},
};

use crate::cli::{AovArg, MethodArg, RenderArgs, ShadowsArg};

/// The outputs a render writes, planned before anything is read.
struct Planned {
    outputs: Outputs,
    exr: OutputId,
    preview: Option<OutputId>,
    depfile: Option<OutputId>,
}

pub fn run(args: &RenderArgs, limits: &Limits, quiet: bool) -> anyhow::Result<()> {
    let start = Instant::now();
    let mut planned = plan(args, limits)?;
    let scene = load::load(&SceneRequest {
        forest: &args.instances,
        terrain: args.terrain.as_deref(),
        day: args.day,
        meshes: args.method != MethodArg::Texel,
        limits: *limits,
    })?;
    let mut dependencies = scene.dependencies.clone();
    planned.outputs.add_inputs(&dependencies)?;
    let views = match &args.camera_file {
        Some(p) => {
            dependencies.push(p.clone());
            import::load_with(p, limits)?
        }
        None => scene.terrain.clone(),
    };
    let camera = camera(args, &scene, &views)?;
    let trees = scene.forest.instances.len();
    let lighting = Lighting {
        sun: view::sun(args.sun, &views.suns),
        shading: Shading::default(),
        sky: args.sky.map(|s| DVec3::from(s).as_vec3()),
    };
    let build_start = Instant::now();
    let mut scene = scene.into_scene(camera.eye, lighting);
    let build = build_start.elapsed().as_secs_f64();
    scene.shadows = !args.no_shadows;

    let pixels = args.crop.map_or(
        u64::from(args.width) * u64::from(args.height),
        |[x0, y0, x1, y1]| u64::from(x1 - x0) * u64::from(y1 - y0),
    );
    let bar = progress_bar(pixels, quiet);
    let render_start = Instant::now();
    let film = render::render(&scene, &camera, &settings(args), &|n| bar.inc(n));
    bar.finish_and_clear();
    let seconds = render_start.elapsed().as_secs_f64();

    write(args, planned, &film, &camera, &dependencies)?;
    if !quiet {
        let rays = pixels * u64::from(args.spp);
        let (samples, shadow_rays) = film.work();
        let (drawn_from, work) = match args.method {
            MethodArg::Texel => (
                "textures",
                format!("{samples:.1} volume samples and {shadow_rays:.1} shadow rays per pixel"),
            ),
            MethodArg::Mesh => ("meshes", format!("{shadow_rays:.1} shadow rays per pixel")),
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
        let memory = texel_forest::limits::peak_memory()
            .map_or(String::new(), |b| format!(", peak memory {} MiB", b >> 20));
        super::summary(&format!(
            "rendered {trees} trees from their {drawn_from}, {}x{} ({pixels} pixels) at {} spp in {seconds:.2} s: {:.0} primary rays/s, {work} -> {} (scene built in {build:.2} s, {:.2} s in all{memory})",
            args.width,
            args.height,
            args.spp,
            rays as f64 / seconds,
            args.output.display(),
            start.elapsed().as_secs_f64()
        ));
    }
    Ok(())
}

/// Checks the frame's size and plans every output, before anything is read.
fn plan(args: &RenderArgs, limits: &Limits) -> anyhow::Result<Planned> {
    let pixels = u64::from(args.width) * u64::from(args.height);
    limits.check_pixels(pixels, "--width x --height")?;
    check_memory(
        pixels.saturating_mul(film::BYTES_PER_PIXEL),
        &format!("a {}x{} frame", args.width, args.height),
    )?;
    if let Some([x0, y0, x1, y1]) = args.crop
        && !(x1 <= args.width && y1 <= args.height)
    {
        bail!(
            "--crop {x0},{y0},{x1},{y1} must lie within the {}x{} frame",
            args.width,
            args.height
        );
    }
    let mut inputs = vec![args.instances.as_path()];
    inputs.extend(args.terrain.as_deref());
    inputs.extend(args.camera_file.as_deref());
    let mut outputs = Outputs::new(&inputs);
    let exr = outputs.add("-o", &args.output)?;
    let preview = args
        .preview
        .as_ref()
        .map(|p| outputs.add("--preview", p))
        .transpose()?;
    let depfile = args
        .depfile
        .as_ref()
        .map(|d| outputs.add("--depfile", d))
        .transpose()?;
    Ok(Planned {
        outputs,
        exr,
        preview,
        depfile,
    })
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
    let camera = view::camera(choice, args.fov, (args.width, args.height), &views.cameras)
        .map_err(|e| anyhow::anyhow!(e))?;
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
    Ok(camera)
}

fn settings(args: &RenderArgs) -> RenderSettings {
    RenderSettings {
        method: match args.method {
            MethodArg::Texel => Method::Texel,
            MethodArg::Mesh => Method::Mesh,
            MethodArg::Hybrid => Method::Hybrid,
        },
        spp: args.spp,
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

/// Encodes the EXR, the preview and the depfile, and commits them together.
fn write(
    args: &RenderArgs,
    mut planned: Planned,
    film: &Film,
    camera: &Camera,
    dependencies: &[std::path::PathBuf],
) -> anyhow::Result<()> {
    let aovs = Aovs {
        normal: args.aov.contains(&AovArg::Normal),
        albedo: args.aov.contains(&AovArg::Albedo),
        canopy: args.aov.contains(&AovArg::Canopy),
        species: args.aov.contains(&AovArg::Species),
        lod: args.aov.contains(&AovArg::Lod),
        samples: args.aov.contains(&AovArg::Samples),
    };
    let exr = film
        .exr_bytes(
            args.half,
            aovs,
            camera.world_to_camera(),
            camera.world_to_ndc(),
        )
        .map_err(|e| anyhow::anyhow!("{}: cannot encode: {e}", args.output.display()))?;
    if exr.clamped > 0 {
        super::warn(&format!(
            "{}: {} values above the half-float maximum (65504) were clamped to it; drop --half to keep them",
            args.output.display(),
            exr.clamped
        ));
    }
    planned.outputs.set(planned.exr, exr.bytes);
    if let Some(p) = planned.preview {
        let png = texel_forest::png::encode(&film.preview(Vec3::new(0.55, 0.68, 0.85)));
        planned.outputs.set(p, png);
    }
    if let Some(d) = planned.depfile {
        planned
            .outputs
            .set(d, depfile(&args.output, dependencies).into_bytes());
    }
    Ok(planned.outputs.commit()?)
}
