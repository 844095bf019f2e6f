//! `texel render`: forest + texels + terrain -> OpenEXR (and a preview).

use std::io::IsTerminal;
use std::time::Instant;

use anyhow::bail;
use glam::{DVec3, Vec3};

use texel_forest::import;
use texel_forest::limits::Limits;
use texel_forest::output::{Outputs, depfile};
use texel_forest::render::load::{self, LoadedScene, SceneRequest};
use texel_forest::render::{
    self, Aovs, Lighting, March, Method, RenderSettings, Scene, Shading,
    view::{self, CameraChoice},
};

use crate::cli::{AovArg, MethodArg, RenderArgs};

pub fn run(args: &RenderArgs, limits: &Limits, quiet: bool) -> anyhow::Result<()> {
    let start = Instant::now();
    // The frame's size and every output are checked before anything is read.
    limits.check_pixels(
        u64::from(args.width) * u64::from(args.height),
        "--width x --height",
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
    let exr_out = outputs.add("-o", &args.output)?;
    let preview_out = args
        .preview
        .as_ref()
        .map(|p| outputs.add("--preview", p))
        .transpose()?;
    let dep_out = args
        .depfile
        .as_ref()
        .map(|d| outputs.add("--depfile", d))
        .transpose()?;

    let scene = load::load(&SceneRequest {
        forest: &args.instances,
        terrain: args.terrain.as_deref(),
        day: args.day,
        meshes: args.method == MethodArg::Mesh,
        limits: *limits,
    })?;
    let mut dependencies = scene.dependencies.clone();
    outputs.add_inputs(&dependencies)?;
    let views = match &args.camera_file {
        Some(p) => {
            dependencies.push(p.clone());
            import::load_with(p, limits)?
        }
        None => scene.terrain.clone(),
    };
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
    if let Some(ground) = scene.ground_height(camera.eye.x, camera.eye.z)
        && camera.eye.y < ground
    {
        let e = camera.eye;
        super::warn(&format!(
            "the eye ({:.1}, {:.1}, {:.1}) is {:.1} m below the terrain, whose surface is at {ground:.1} m there: the render shows the terrain's underside",
            e.x,
            e.y,
            e.z,
            ground - e.y
        ));
    }
    let sun = view::sun(args.sun, &views.suns);

    let LoadedScene {
        forest,
        texels,
        looks,
        placed,
        terrain,
        meshes,
        ..
    } = scene;
    let lighting = Lighting {
        sun,
        shading: Shading::default(),
        sky: args.sky.map(|s| DVec3::from(s).as_vec3()),
    };
    let scene = Scene::new(
        camera.eye,
        texels,
        looks,
        &placed,
        Some(terrain.mesh),
        lighting,
    );
    let scene = match meshes {
        Some(m) => scene.with_meshes(m),
        None => scene,
    };
    let settings = RenderSettings {
        method: match args.method {
            MethodArg::Texel => Method::Texel,
            MethodArg::Mesh => Method::Mesh,
        },
        spp: args.spp,
        march: March {
            step: args.step,
            cutoff: args.cutoff,
            lod_bias: args.lod_bias,
            shadow_lod: args.shadow_lod,
            shadow_share: args.shadow_share,
        },
        crop: args.crop,
        seed: args.seed,
    };

    let pixels = args.crop.map_or(
        u64::from(args.width) * u64::from(args.height),
        |[x0, y0, x1, y1]| u64::from(x1 - x0) * u64::from(y1 - y0),
    );
    let bar = if quiet || !std::io::stderr().is_terminal() {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(pixels).with_style(
            indicatif::ProgressStyle::with_template(
                "{elapsed_precise} [{bar:40}] {percent}% {msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        )
    };
    let render_start = Instant::now();
    let film = render::render(&scene, &camera, &settings, &|n| bar.inc(n));
    bar.finish_and_clear();
    let seconds = render_start.elapsed().as_secs_f64();

    let aovs = Aovs {
        normal: args.aov.contains(&AovArg::Normal),
        albedo: args.aov.contains(&AovArg::Albedo),
        canopy: args.aov.contains(&AovArg::Canopy),
        species: args.aov.contains(&AovArg::Species),
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
    outputs.set(exr_out, exr.bytes);
    if let Some(p) = preview_out {
        let png = texel_forest::png::encode(&film.preview(Vec3::new(0.55, 0.68, 0.85)));
        outputs.set(p, png);
    }
    if let Some(d) = dep_out {
        outputs.set(d, depfile(&args.output, &dependencies).into_bytes());
    }
    outputs.commit()?;
    if !quiet {
        let rays = pixels * u64::from(args.spp);
        let (samples, shadow_rays) = film.work();
        let work = match args.method {
            MethodArg::Texel => {
                format!("{samples:.1} volume samples and {shadow_rays:.1} shadow rays per pixel")
            }
            MethodArg::Mesh => format!("{shadow_rays:.1} shadow rays per pixel"),
        };
        eprintln!(
            "texel: rendered {} trees from their {}, {}x{} ({} pixels) at {} spp in {seconds:.2} s: {:.0} primary rays/s, {work} -> {} ({:.2} s in all)",
            forest.instances.len(),
            match args.method {
                MethodArg::Texel => "textures",
                MethodArg::Mesh => "meshes",
            },
            args.width,
            args.height,
            pixels,
            args.spp,
            rays as f64 / seconds,
            args.output.display(),
            start.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
