//! `texel render`: forest + texels + terrain -> OpenEXR (and a preview).

use std::collections::HashMap;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use glam::{DVec3, Vec3};
use sha2::{Digest, Sha256};

use texel_forest::bake;
use texel_forest::formats::{hex, instances, texel};
use texel_forest::import;
use texel_forest::output::{depfile, write_atomic};
use texel_forest::render::mesh::TreeMesh;
use texel_forest::render::{
    self, Aovs, Camera, Lighting, Look, March, Method, Placed, RenderSettings, Scene, Shading, Sun,
};
use texel_forest::volume::Texel;

use crate::cli::{AovArg, MethodArg, RenderArgs};

/// Afternoon light from the south-west when nothing says otherwise.
const DEFAULT_SUN: (f64, f64) = (225.0, 35.0);
const DEFAULT_FOV: f64 = 35.0;

fn numbers<const N: usize>(s: &str, flag: &str, what: &str) -> anyhow::Result<[f64; N]> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .unwrap_or_default();
    match <[f64; N]>::try_from(v) {
        Ok(a) if a.iter().all(|x| x.is_finite()) => Ok(a),
        _ => bail!("{flag} {s:?}: expected {what}"),
    }
}

/// Reads `path`, refusing it if its SHA-256 is not `recorded` (the input changed since the
/// forest was placed).
fn read_checked(path: &Path, recorded: &[u8; 32], forest: &Path) -> anyhow::Result<Vec<u8>> {
    let bytes = std::fs::read(path)
        .with_context(|| format!("{}: cannot read {}", forest.display(), path.display()))?;
    let hash: [u8; 32] = Sha256::digest(&bytes).into();
    if &hash != recorded {
        bail!(
            "{}: {} changed since the forest was placed (sha256 {} recorded, {} now); re-run texel place",
            forest.display(),
            path.display(),
            &hex(recorded)[..12],
            &hex(&hash)[..12]
        );
    }
    Ok(bytes)
}

pub fn run(args: &RenderArgs, quiet: bool) -> anyhow::Result<()> {
    let start = Instant::now();
    if args.spp == 0 {
        bail!("--spp must be at least 1");
    }
    if !(args.step > 0.0 && args.step.is_finite()) {
        bail!("--step {} must be a positive number of cells", args.step);
    }
    if !(0.0..1.0).contains(&args.cutoff) {
        bail!("--cutoff {} must be a transmittance in [0, 1)", args.cutoff);
    }
    if !(0.0..=1.0).contains(&args.shadow_share) {
        bail!(
            "--shadow-share {} must be a share of a pixel in [0, 1]",
            args.shadow_share
        );
    }
    if !(args.lod_bias.is_finite() && args.shadow_lod.is_finite() && args.shadow_lod >= 0.0) {
        bail!(
            "--lod-bias {} and --shadow-lod {} must be finite (and --shadow-lod not negative)",
            args.lod_bias,
            args.shadow_lod
        );
    }
    if !(1.0..=366.0).contains(&args.day) {
        bail!("--day {} is not a day of the year (1 to 366)", args.day);
    }
    let crop = args
        .crop
        .as_deref()
        .map(|s| numbers::<4>(s, "--crop", "four pixel numbers X0,Y0,X1,Y1"))
        .transpose()?
        .map(|c| c.map(|v| v as u32));
    if let Some([x0, y0, x1, y1]) = crop
        && !(x0 < x1 && y0 < y1 && x1 <= args.width && y1 <= args.height)
    {
        bail!(
            "--crop {x0},{y0},{x1},{y1} must lie within the {}x{} frame, x0 < x1 and y0 < y1",
            args.width,
            args.height
        );
    }
    let sky = args
        .sky
        .as_deref()
        .map(|s| numbers::<3>(s, "--sky", "three radiances R,G,B"))
        .transpose()?;

    // Everything is read and checked before any rendering starts.
    let forest_bytes = std::fs::read(&args.instances)
        .with_context(|| format!("cannot read {}", args.instances.display()))?;
    let forest =
        instances::decode(&forest_bytes).with_context(|| args.instances.display().to_string())?;
    let dir = args
        .instances
        .parent()
        .unwrap_or(Path::new(""))
        .to_path_buf();
    let mut dependencies = vec![args.instances.clone()];
    let terrain_path = args
        .terrain
        .clone()
        .unwrap_or_else(|| dir.join(&forest.info.terrain[0].path));
    read_checked(
        &terrain_path,
        &forest.info.terrain[0].sha256,
        &args.instances,
    )?;
    let terrain = import::load_surface(&terrain_path, "to render as a terrain")?;
    dependencies.extend(terrain.sources.iter().map(|s| s.path.clone()));

    let mut texels: Vec<Texel> = Vec::new();
    let mut texel_paths: Vec<PathBuf> = Vec::new();
    let mut loaded: HashMap<PathBuf, usize> = HashMap::new();
    let mut load = |rel: &str, sha: &[u8; 32]| -> anyhow::Result<usize> {
        let path = dir.join(rel);
        if let Some(&i) = loaded.get(&path) {
            return Ok(i);
        }
        let bytes = read_checked(&path, sha, &args.instances)?;
        let t = texel::decode(&bytes).with_context(|| path.display().to_string())?;
        texels.push(t);
        texel_paths.push(path.clone());
        loaded.insert(path.clone(), texels.len() - 1);
        dependencies.push(path);
        Ok(texels.len() - 1)
    };
    let mut looks = Vec::new();
    for s in &forest.info.species {
        let leaf_fraction = s.seasons.leaf_fraction(args.day) as f32;
        let albedo = s.seasons.albedo(args.day).map(|c| c as f32);
        // A bare deciduous tree draws its leafless texture where it has one.
        let (texel, foliage) = match (&s.leafless_texel, &s.leafless_sha256) {
            (Some(path), Some(sha)) if leaf_fraction <= 0.0 => (load(path, sha)?, 0.0),
            _ => (load(&s.texel, &s.texel_sha256)?, leaf_fraction),
        };
        looks.push(Look {
            texel,
            foliage,
            foliage_albedo: Vec3::from(albedo),
        });
    }
    // Heights were scaled for the texel's model: a rebaked texel must still match.
    for (s, look) in forest.info.species.iter().zip(&looks) {
        let info = &texels[look.texel].info;
        let height = info.model_max[1] - info.model_min[1];
        if look.foliage > 0.0 && (height - s.model_height).abs() > 1e-6 * s.model_height.max(1.0) {
            bail!(
                "{}: species {:?}: the texel's model is {height} tall, the forest was placed for {}",
                args.instances.display(),
                s.name,
                s.model_height
            );
        }
    }

    let meshes = match args.method {
        MethodArg::Texel => None,
        MethodArg::Mesh => Some(tree_meshes(&texels, &texel_paths, &mut dependencies)?),
    };

    // Camera and sun: flags, else the glTF's, else defaults that frame the whole terrain.
    let views = match &args.camera_file {
        Some(p) => {
            dependencies.push(p.clone());
            import::load(p)?
        }
        None => terrain.clone(),
    };
    let fov = args.fov.unwrap_or(DEFAULT_FOV);
    let camera = if let (Some(e), Some(t)) = (&args.eye, &args.target) {
        let eye = DVec3::from(numbers::<3>(e, "--eye", "three numbers X,Y,Z")?);
        let target = DVec3::from(numbers::<3>(t, "--target", "three numbers X,Y,Z")?);
        Camera::look_at(eye, target, fov, args.width, args.height)
            .map_err(|e| anyhow::anyhow!("--eye/--target: {e}"))?
    } else if let Some(name) = &args.camera {
        let Some(c) = views.cameras.iter().find(|c| &c.name == name) else {
            let names: Vec<&str> = views.cameras.iter().map(|c| c.name.as_str()).collect();
            bail!(
                "--camera {name:?}: no such camera (the glTF has: {})",
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                }
            );
        };
        let vfov = args.fov.map_or(c.yfov, f64::to_radians);
        Camera::from_frame(c.eye, c.forward, c.up, vfov, args.width, args.height)
            .map_err(|e| anyhow::anyhow!("--camera {name:?}: {e}"))?
    } else {
        frame_terrain(&terrain.mesh, fov, args.width, args.height)?
    };
    let sun = match (&args.sun, views.suns.first()) {
        (Some(s), _) => {
            let [az, el] =
                numbers::<2>(s, "--sun", "an azimuth and an elevation in degrees, AZ,EL")?;
            if !(-90.0..=90.0).contains(&el) {
                bail!("--sun {s}: elevation {el} must be within -90..90 degrees");
            }
            Sun::from_angles(az, el, std::f32::consts::PI)
        }
        (None, Some(light)) => Sun {
            direction: light.towards.as_vec3(),
            irradiance: std::f32::consts::PI,
        },
        (None, None) => Sun::from_angles(DEFAULT_SUN.0, DEFAULT_SUN.1, std::f32::consts::PI),
    };

    let placed: Vec<Placed> = forest
        .instances
        .iter()
        .map(|p| Placed {
            look: p.species as u16,
            position: DVec3::from(p.position),
            rotation: p.rotation,
            scale: p.scale,
        })
        .collect();
    let lighting = Lighting {
        sun,
        shading: Shading::default(),
        sky: sky.map(|s| DVec3::from(s).as_vec3()),
    };
    let scene = Scene::new(
        camera.eye,
        texels,
        looks,
        &placed,
        Some(terrain.mesh.clone()),
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
        crop,
        seed: args.seed,
    };

    let pixels = crop.map_or(
        args.width as u64 * args.height as u64,
        |[x0, y0, x1, y1]| (x1 - x0) as u64 * (y1 - y0) as u64,
    );
    let bar = if quiet || !std::io::stderr().is_terminal() {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(pixels).with_style(
            indicatif::ProgressStyle::with_template(
                "{elapsed_precise} [{bar:40}] {percent}% {msg}",
            )
            .expect("a valid template"),
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
    super::output_dir(&args.output)?;
    write_atomic(&args.output, &exr)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    if let Some(p) = &args.preview {
        super::output_dir(p)?;
        let png =
            texel_forest::inspect::pictures::png_bytes(&film.preview(Vec3::new(0.55, 0.68, 0.85)));
        write_atomic(p, &png).with_context(|| format!("cannot write {}", p.display()))?;
    }
    if let Some(d) = &args.depfile {
        write_atomic(d, depfile(&args.output, &dependencies).as_bytes())
            .with_context(|| format!("cannot write {}", d.display()))?;
    }
    if !quiet {
        let rays = pixels * args.spp as u64;
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

/// The polygon model each texel was baked from (its first recorded source, relative to the
/// texel), refused if any of its files changed since the bake, with its foliage picked out by
/// the bake's own pattern.
fn tree_meshes(
    texels: &[Texel],
    paths: &[PathBuf],
    dependencies: &mut Vec<PathBuf>,
) -> anyhow::Result<Vec<TreeMesh>> {
    let mut meshes = Vec::new();
    for (t, path) in texels.iter().zip(paths) {
        let dir = path.parent().unwrap_or(Path::new(""));
        let Some(model) = t.info.sources.first() else {
            bail!(
                "{}: records no source model (made by {:?}); --method mesh needs the glTF it was baked from",
                path.display(),
                t.info.generator
            );
        };
        for source in &t.info.sources {
            let file = dir.join(&source.path);
            let bytes = std::fs::read(&file).with_context(|| {
                format!(
                    "{}: cannot read its source {} (--method mesh draws the models the texels were baked from)",
                    path.display(),
                    file.display()
                )
            })?;
            let hash: [u8; 32] = Sha256::digest(&bytes).into();
            if hash != source.sha256 {
                bail!(
                    "{}: its source {} changed since it was baked (sha256 {} recorded, {} now); re-run texel bake",
                    path.display(),
                    file.display(),
                    &hex(&source.sha256)[..12],
                    &hex(&hash)[..12]
                );
            }
            dependencies.push(file);
        }
        let file = dir.join(&model.path);
        let m = import::load_surface(&file, "to draw as a tree")?;
        let foliage = bake::foliage_triangles(&m.mesh, &t.info.parameters)
            .with_context(|| path.display().to_string())?;
        meshes.push(TreeMesh::new(m.mesh, foliage));
    }
    Ok(meshes)
}

/// A distant view of the whole terrain from the south-south-west, 25 degrees above it, aimed
/// and distanced so the terrain's bounding box fills most of the frame.
fn frame_terrain(mesh: &import::Mesh, fov: f64, width: u32, height: u32) -> anyhow::Result<Camera> {
    let Some((lo, hi)) = mesh.bounds() else {
        bail!("the terrain has no triangles to frame")
    };
    let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
    let corners: Vec<DVec3> = (0..8)
        .map(|k| {
            DVec3::new(
                [lo.x, hi.x][k & 1],
                [lo.y, hi.y][(k >> 1) & 1],
                [lo.z, hi.z][k >> 2],
            )
        })
        .collect();
    let (az, el) = (200f64.to_radians(), 25f64.to_radians());
    let towards_eye = DVec3::new(az.sin() * el.cos(), el.sin(), -az.cos() * el.cos());
    let mut target = (lo + hi) * 0.5;
    let mut distance = (hi - lo).length();
    let mut camera = Camera::look_at(target + towards_eye * distance, target, fov, width, height)
        .map_err(|e| anyhow::anyhow!(e))?;
    // A few rounds of: project the box, re-aim at the middle of its image, and move in or out
    // until it spans 90% of the frame's tighter side.
    for _ in 0..6 {
        let m = camera.world_to_ndc();
        let ndc: Vec<(f64, f64)> = corners
            .iter()
            .map(|p| {
                let v = [p.x, p.y, p.z, 1.0];
                let c: [f64; 4] =
                    std::array::from_fn(|j| (0..4).map(|i| v[i] * m[4 * i + j] as f64).sum());
                (c[0] / c[3], c[1] / c[3])
            })
            .collect();
        let (x0, x1) = ndc
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.0), b.max(p.0))
            });
        let (y0, y1) = ndc
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.1), b.max(p.1))
            });
        let (cx, cy) = ((x0 + x1) * 0.5, (y0 + y1) * 0.5);
        let aim = camera
            .direction(cx * width as f64, cy * height as f64)
            .as_dvec3();
        target = camera.eye + aim * (target - camera.eye).length();
        distance *= ((x1 - x0).max(y1 - y0) / 0.9).clamp(0.5, 2.0);
        camera = Camera::look_at(target + towards_eye * distance, target, fov, width, height)
            .map_err(|e| anyhow::anyhow!(e))?;
    }
    Ok(camera)
}
