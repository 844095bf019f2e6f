//! The renderer against answers known in closed form, and on the hard cases.

use glam::{DVec3, Vec3, Vec4};

use super::integrate::radiance;
use super::lod::Draw;
use super::scene::{Lighting, Look, Placed, Scene, Shading, Sun};
use super::sunlight::{Caster, OwnTree, transmittance};
use super::walk::{March, ShadowRays};
use super::{Camera, Edges, RenderSettings, render};
use crate::bake::{mip_chain, sobel};
use crate::geom::Ray;
use crate::import::{Material, Mesh};
use crate::rng;
use crate::volume::{
    BakeParameters, DensityModel, ISOTROPIC_LEAVES, Level, SelfShadow, Texel, TexelInfo,
};

/// A texture of `dims` cells of edge `cell` from `origin`, holding wood of uniform extinction
/// `sigma` (1/m) and colour `albedo`.
pub(crate) fn uniform_texel(
    dims: [usize; 3],
    cell: f64,
    origin: DVec3,
    sigma: f32,
    albedo: [f32; 3],
) -> Texel {
    let mut l = Level::empty(dims, cell);
    l.density[0] = vec![sigma; l.cell_count()];
    l.albedo[0] = vec![albedo; l.cell_count()];
    l.gradient[0] = sobel::gradient(&l.density[0], dims, cell);
    let hi = origin + DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64) * cell;
    Texel {
        info: TexelInfo {
            generator: "test".into(),
            model_min: origin.to_array(),
            model_max: hi.to_array(),
            origin: origin.to_array(),
            density_model: DensityModel::Transmittance,
            extinction_scale: 1.0,
            triangles: 0,
            foliage_triangles: 0,
            mesh_coverage: [0.0; 3],
            sources: vec![],
            inputs_sha256: [0; 32],
            parameters: BakeParameters {
                resolution: 0,
                fine: 0,
                foliage_pattern: String::new(),
                requested_gamma: None,
                wood_pattern: None,
            },
            materials: vec![],
        },
        levels: mip_chain(l, 1.0),
    }
}

pub(super) fn look() -> Look {
    Look {
        texel: 0,
        foliage: 1.0,
        foliage_albedo: Vec3::splat(0.5),
    }
}

pub(super) fn placed(position: DVec3) -> Placed {
    Placed {
        look: 0,
        position,
        rotation: 0.0,
        scale: 1.0,
    }
}

/// A flat square of ground at height `y`, `half` metres each way, of albedo `albedo`.
pub(super) fn ground(y: f32, half: f32, albedo: f32) -> Mesh {
    let p = [(-half, -half), (half, -half), (half, half), (-half, half)]
        .map(|(x, z)| Vec3::new(x, y, z));
    Mesh::plain(
        p.to_vec(),
        &[[0, 2, 1], [0, 3, 2]],
        Material {
            base_color: Vec4::new(albedo, albedo, albedo, 1.0),
            ..Material::default()
        },
    )
}

pub(super) const PLAIN: Shading = Shading {
    kd: 1.0,
    ks: 0.0,
    shininess: 1.0,
    ambient: 0.0,
};
pub(super) const HEAD_ON: Sun = Sun {
    direction: Vec3::Z,
    irradiance: std::f32::consts::PI,
};

#[test]
fn a_homogeneous_texel_seen_along_an_axis_transmits_exp_minus_sigma_length() {
    for sigma in [1e-8f32, 0.05, 0.7, 3.0] {
        let texel = uniform_texel([8, 8, 8], 0.25, DVec3::ZERO, sigma, [0.5; 3]);
        let scene = Scene::new(
            DVec3::new(1.0, 1.0, 10.0),
            vec![texel],
            vec![look()],
            &[placed(DVec3::ZERO)],
            None,
            Lighting {
                sun: HEAD_ON,
                shading: PLAIN,
                sky: None,
            },
        );
        let t = transmittance(
            &scene,
            Ray {
                origin: Vec3::new(0.0, 0.0, 5.0),
                dir: Vec3::NEG_Z,
            },
            f32::INFINITY,
            &March {
                cutoff: 0.0,
                ..March::default()
            },
            &Caster {
                footprint: 0.0,
                key: 7,
                own: &[],
                draw: &Draw::Texel,
            },
        );
        let want = (-sigma * 2.0).exp();
        assert!(
            (t - want).abs() < 1e-3 * want.max(1e-3),
            "sigma {sigma}: {t} vs {want}"
        );
        // The primary ray sees the same: its alpha is 1 - T (marched to the end, not
        // rouletted: one ray's transmittance is then exact, not only in expectation).
        let r = radiance(
            &scene,
            Vec3::NEG_Z,
            0.0,
            3,
            &March {
                cutoff: 0.0,
                view_share: 0.0,
                ..March::default()
            },
        );
        assert!(
            (r.transmittance - want).abs() < 1e-3 * want.max(1e-3),
            "{} vs {want}",
            r.transmittance
        );
    }
}

/// A level's directional form scales extinction by `sqrt(q(w))` along the ray's direction in
/// model space: along z by `sqrt(S_zz + c)`, along a turned instance's x likewise by its
/// model-space direction, for view and shadow rays alike.
#[test]
fn directional_extinction_scales_optical_depth_by_the_form() {
    let sigma = 0.4f32;
    let mut texel = uniform_texel([8, 8, 8], 0.25, DVec3::ZERO, sigma, [0.5; 3]);
    let form = [0.5f32, 2.0, 1.44, 0.0, 0.0, 0.0, 0.25];
    for l in &mut texel.levels {
        l.directional = form;
    }
    let along_z = (form[2] + form[6]).sqrt();
    let along_x = (form[0] + form[6]).sqrt();
    for (rotation, k) in [(0.0f32, along_z), (std::f32::consts::FRAC_PI_2, along_x)] {
        let scene = Scene::new(
            DVec3::new(1.0, 1.0, 10.0),
            vec![texel.clone()],
            vec![look()],
            &[Placed {
                rotation,
                ..placed(DVec3::new(0.0, 0.0, 0.0))
            }],
            None,
            Lighting {
                sun: HEAD_ON,
                shading: PLAIN,
                sky: None,
            },
        );
        let march = March {
            cutoff: 0.0,
            ..March::default()
        };
        // Through the middle of the (possibly turned) box, 2 m of it either way.
        let dir = Vec3::NEG_Z;
        let t = transmittance(
            &scene,
            Ray {
                origin: Vec3::new(0.0, 0.0, 5.0),
                dir,
            },
            f32::INFINITY,
            &march,
            &Caster {
                footprint: 0.0,
                key: 7,
                own: &[],
                draw: &Draw::Texel,
            },
        );
        let want = (-sigma * 2.0 * k).exp();
        assert!(
            (t - want).abs() < 1e-3 * want,
            "rotation {rotation}: {t} vs {want}"
        );
        let r = radiance(&scene, dir, 0.0, 3, &march);
        assert!(
            (r.transmittance - want).abs() < 1e-3 * want,
            "{} vs {want}",
            r.transmittance
        );
    }
}

/// The albedo of [`opaque_slab`].
const SLAB_ALBEDO: [f32; 3] = [0.6, 0.4, 0.2];

/// A slab 4 m x 4 m x 1 m, very dense, facing +z, with the eye 10 m in front of it on +z and
/// lit by `sun` with plain shading.
fn opaque_slab(sun: Sun) -> Scene {
    let texel = uniform_texel(
        [16, 16, 4],
        0.25,
        DVec3::new(-2.0, -2.0, -1.0),
        200.0,
        SLAB_ALBEDO,
    );
    lone_scene(texel, DVec3::new(0.0, 0.0, 10.0), sun)
}

/// One tree of `texel` at the origin, seen from `eye`, lit by `sun` with plain shading, no
/// terrain and no sky.
fn lone_scene(texel: Texel, eye: DVec3, sun: Sun) -> Scene {
    Scene::new(
        eye,
        vec![texel],
        vec![look()],
        &[placed(DVec3::ZERO)],
        None,
        Lighting {
            sun,
            shading: PLAIN,
            sky: None,
        },
    )
}

#[test]
fn an_opaque_slab_lit_head_on_gives_the_lambert_radiance() {
    let albedo = SLAB_ALBEDO;
    let scene = opaque_slab(HEAD_ON);
    // Lambert: albedo x (irradiance / pi) x cos 0 = albedo.
    let r = radiance(&scene, Vec3::NEG_Z, 0.0, 11, &March::default());
    assert!(r.transmittance < 1e-3);
    assert!(r.normal.dot(Vec3::Z) > 0.999, "{:?}", r.normal);
    // Lit from 60 degrees off the normal, a third of... half as bright: cos 60.
    let oblique = Sun {
        direction: Vec3::new(0.0, 60f32.to_radians().sin(), 60f32.to_radians().cos()),
        irradiance: std::f32::consts::PI,
    };
    let scene = Scene {
        sun: oblique,
        ..scene
    };
    let r = radiance(&scene, Vec3::NEG_Z, 0.0, 11, &March::default());
    assert!(
        (r.rgb[0] - 0.5 * albedo[0]).abs() < 0.01 * albedo[0],
        "{:?}",
        r.rgb
    );
    // The segment weights add up to 1 - T whatever the step (unlike a Riemann sum of
    // gamma rho dt): under ambient light alone, where neither normal nor shadow matter, the
    // slab shows exactly albedo x ambient for steps from a quarter cell to the whole slab.
    let ambient_only = Scene {
        sun: Sun {
            irradiance: 0.0,
            ..oblique
        },
        shading: Shading {
            ambient: 1.0,
            ..PLAIN
        },
        ..scene
    };
    for step in [0.25, 0.5, 1.0, 2.0, 4.0] {
        let r = radiance(
            &ambient_only,
            Vec3::NEG_Z,
            0.0,
            11,
            &March {
                step,
                ..March::default()
            },
        );
        for c in 0..3 {
            assert!(
                (r.rgb[c] - albedo[c]).abs() < 1e-3 * albedo[c],
                "step {step}: {:?} vs {albedo:?}",
                r.rgb
            );
        }
    }
}

#[test]
fn a_ground_quad_under_a_known_slab_gets_the_predicted_transmittance() {
    // A horizontal slab 1 m thick of extinction 0.8 / m, 10 m above the ground; sun at zenith.
    let (sigma, thickness) = (0.8f32, 1.0f32);
    let texel = uniform_texel(
        [16, 4, 16],
        0.25,
        DVec3::new(-2.0, 10.0, -2.0),
        sigma,
        [0.5; 3],
    );
    let sun = Sun::from_angles(0.0, 90.0, std::f32::consts::PI);
    let scene = Scene::new(
        DVec3::new(0.0, 5.0, 0.0),
        vec![texel],
        vec![look()],
        &[placed(DVec3::ZERO)],
        Some(ground(0.0, 50.0, 0.4)),
        Lighting {
            sun,
            shading: PLAIN,
            sky: None,
        },
    );
    // Looking straight down at the ground below the slab's centre (the eye under the slab).
    let r = radiance(&scene, Vec3::NEG_Y, 0.0, 5, &March::default());
    let want = 0.4 * (-sigma * thickness).exp();
    assert!((r.rgb[0] - want).abs() < 1e-3, "{} vs {want}", r.rgb[0]);
    // Outside the slab's shadow the ground is fully lit.
    let r = radiance(
        &scene,
        Vec3::new(0.8, -0.6, 0.0).normalize(),
        0.0,
        5,
        &March::default(),
    );
    assert!((r.rgb[0] - 0.4).abs() < 1e-3, "{}", r.rgb[0]);
    // Without shadows the ground below the slab is lit in full, and no shadow ray is cast.
    let mut scene = scene;
    scene.shadows = false;
    let r = radiance(&scene, Vec3::NEG_Y, 0.0, 5, &March::default());
    assert!((r.rgb[0] - 0.4).abs() < 1e-6, "{}", r.rgb[0]);
    assert_eq!(r.shadow_rays, 0);
}

/// A ball of fog: density falling off from the centre, so one sample per cell is noisy, seen
/// whole by a 24 x 24 camera in afternoon light.
fn fog_ball() -> (Scene, Camera) {
    let n = 16;
    let mut l = Level::empty([n; 3], 0.25);
    for i in 0..l.cell_count() {
        let c = [i % n, (i / n) % n, i / (n * n)].map(|v| (v as f32 + 0.5) / n as f32 - 0.5);
        let r = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        l.density[1][i] = (1.0 - 2.0 * r).max(0.0) * 6.0;
        l.albedo[1][i] = [0.3, 0.6, 0.2];
    }
    l.gradient[1] = sobel::gradient(&l.density[1], [n; 3], 0.25);
    let mut texel = uniform_texel([n; 3], 0.25, DVec3::splat(-2.0), 0.0, [0.5; 3]);
    texel.levels = mip_chain(l, 1.0);
    let sun = Sun::from_angles(200.0, 40.0, std::f32::consts::PI);
    let scene = Scene::new(
        DVec3::new(0.3, 0.2, 8.0),
        vec![texel],
        vec![look()],
        &[placed(DVec3::ZERO)],
        None,
        Lighting {
            sun,
            shading: Shading::default(),
            sky: None,
        },
    );
    let camera = Camera::look_at(scene.origin, DVec3::ZERO, 30.0, 24, 24).unwrap();
    (scene, camera)
}

/// The root of the mean over pixels of the squared differences of two films' RGBA
/// `channels`, summed over the channels.
fn rms_difference(a: &super::Film, b: &super::Film, channels: &[usize]) -> f64 {
    let e: f64 = a
        .rgba
        .iter()
        .zip(&b.rgba)
        .map(|(p, q)| {
            channels
                .iter()
                .map(|&c| f64::from(p[c] - q[c]).powi(2))
                .sum::<f64>()
        })
        .sum();
    (e / a.rgba.len() as f64).sqrt()
}

#[test]
fn the_stratified_estimator_converges_as_samples_grow() {
    let (scene, camera) = fog_ball();
    let image = |spp: u32| {
        render(
            &scene,
            &camera,
            &RenderSettings {
                spp,
                ..RenderSettings::default()
            },
            &|_| {},
        )
    };
    let reference = image(256);
    let error = |spp: u32| rms_difference(&image(spp), &reference, &[0, 3]);
    let errors: Vec<f64> = [1, 4, 16].iter().map(|&s| error(s)).collect();
    println!("rms error at 1, 4, 16 spp: {errors:?}");
    assert!(errors[0] > errors[1] && errors[1] > errors[2], "{errors:?}");
    assert!(errors[2] < 0.5 * errors[0], "{errors:?}");
}

/// A pixel's strata have equal areas and tile it for every count of samples, as nearly square
/// as the count allows, and a jittered sample stays in the stratum whose centre the centred
/// one takes. (Before, `spp` not a square left strata empty: at 2 spp both samples lay in the
/// pixel's top half.)
#[test]
fn the_strata_tile_the_pixel_with_equal_areas_for_any_count() {
    for spp in (1..=50).chain([64, 97, 256, 1000, 65521, 65536]) {
        let strata = super::Strata::new(spp);
        let (c, r) = (strata.columns, strata.rows);
        assert_eq!(c * r, spp, "{spp}: {strata:?}");
        assert!(r <= c, "{spp}: {strata:?}");
        // As square as can be: no divisor of spp lies between the rows and its square root.
        assert!(
            ((r + 1)..=spp.isqrt()).all(|d| !spp.is_multiple_of(d)),
            "{spp}: {strata:?}"
        );
        let mut seen = vec![false; spp as usize];
        for s in 0..spp {
            let (u, v) = strata.place(s, None);
            let cell = |u: f64, v: f64| {
                ((v * r as f64).floor() as u32 * c + (u * c as f64).floor() as u32) as usize
            };
            let i = cell(u, v);
            assert!(!seen[i], "{spp}: sample {s} in a stratum already taken");
            seen[i] = true;
            // Within the stratum, to the rounding of (i + u) / columns.
            let within = |a: f64, centre: f64, n: u32| (a - centre).abs() * n as f64 <= 0.5 + 1e-9;
            for key in [1u64, 2, 3, 0xdead_beef] {
                let (ju, jv) = strata.place(s, Some(rng::mix64(key ^ u64::from(s))));
                assert!((0.0..=1.0).contains(&ju) && (0.0..=1.0).contains(&jv));
                assert!(
                    within(ju, u, c) && within(jv, v, r),
                    "{spp}: sample {s} jittered out of its stratum"
                );
            }
        }
    }
}

/// Centred samples (the default) against jittered ones, on a volume whose texture the
/// footprint's level smooths: the midpoint rule's error is second order in the stratum's size,
/// a jittered sample's noise first order, so the centred image lies nearer the unbiased
/// (jittered) 256-spp reference than jittered images with any of four seeds: by more than a
/// fifth at 1 spp (measured 0.057 against 0.077-0.083), and still below at 4 (0.028 against
/// 0.031-0.033), where the ray's own draws are most of what is left.
#[test]
fn centred_samples_are_nearer_the_reference_than_jittered_ones_on_a_smooth_volume() {
    let (scene, camera) = fog_ball();
    let image = |spp: u32, jitter: bool, seed: u64| {
        render(
            &scene,
            &camera,
            &RenderSettings {
                spp,
                jitter,
                seed,
                ..RenderSettings::default()
            },
            &|_| {},
        )
    };
    let reference = image(256, true, 99);
    let error = |f: &super::Film| rms_difference(f, &reference, &[0, 1, 2, 3]);
    for spp in [1, 4] {
        let centred = error(&image(spp, false, 0));
        let jittered: Vec<f64> = (1..=4).map(|seed| error(&image(spp, true, seed))).collect();
        println!("{spp} spp: centred {centred:.5}, jittered {jittered:.5?}");
        let best = jittered.iter().copied().fold(f64::INFINITY, f64::min);
        let margin = if spp == 1 { 0.8 } else { 1.0 };
        assert!(
            centred < margin * best,
            "{spp} spp: {centred} against {jittered:?}"
        );
    }
}

/// Jumping over empty bricks skips only whole segments that hold nothing, with their random
/// draws, and a step whose trilinear stencils are all empty reads no cell: the same image (to
/// rounding), for one dense cell alone in a large empty box (500x fewer samples read a
/// texture) and for the fog ball (whose bricks are all occupied: only the empty cells of its
/// border are not read).
#[test]
fn skipping_empty_space_changes_the_work_not_the_image() {
    let mut l = Level::empty([32, 24, 28], 0.125);
    let i = l.index(20, 9, 6);
    l.density[1][i] = 40.0;
    l.albedo[1][i] = [0.3, 0.6, 0.2];
    l.gradient[1] = sobel::gradient(&l.density[1], l.dims, 0.125);
    let mut texel = uniform_texel([32, 24, 28], 0.125, DVec3::splat(-2.0), 0.0, [0.5; 3]);
    texel.levels = mip_chain(l, 1.0);
    let (fog, fog_camera) = fog_ball();
    let lone = Scene::new(
        DVec3::new(0.8, 0.3, 6.0),
        vec![texel],
        vec![look()],
        &[placed(DVec3::ZERO)],
        None,
        Lighting {
            sun: Sun::from_angles(200.0, 40.0, std::f32::consts::PI),
            shading: Shading::default(),
            sky: None,
        },
    );
    let lone_camera =
        Camera::look_at(lone.origin, DVec3::new(0.56, -0.8, -1.2), 12.0, 24, 24).unwrap();
    for (name, mut scene, camera, fewer) in [
        ("one cell", lone, lone_camera, 0.002),
        ("fog ball", fog, fog_camera, 1.0),
    ] {
        let settings = RenderSettings {
            spp: 64,
            ..RenderSettings::default()
        };
        let skipping = render(&scene, &camera, &settings, &|_| {});
        scene.occupancy = scene
            .texels
            .iter()
            .map(|t| {
                t.levels
                    .iter()
                    .map(crate::volume::Occupancy::dense)
                    .collect()
            })
            .collect();
        let every = render(&scene, &camera, &settings, &|_| {});
        let sum = |f: &super::Film, c: usize| f.rgba.iter().map(|p| f64::from(p[c])).sum::<f64>();
        for c in [1, 3] {
            let (a, b) = (sum(&skipping, c), sum(&every, c));
            println!("{name}: channel {c} summed {a} skipping, {b} marching every cell");
        }
        for c in [1, 3] {
            let (a, b) = (sum(&skipping, c), sum(&every, c));
            assert!(
                a > 0.0 && (a - b).abs() < 1e-6 * b,
                "{name} channel {c}: {a} vs {b}"
            );
        }
        let (a, b) = (skipping.work().0, every.work().0);
        println!("{name}: {a} volume samples per pixel skipping, {b} marching every cell");
        assert!(a <= fewer * b, "{name}: {a} vs {b}");
    }
}

/// The fog ball at 256 samples per pixel, marched as `march` says.
fn fog_ball_at_256_spp(march: March) -> super::Film {
    let (scene, camera) = fog_ball();
    let settings = RenderSettings {
        spp: 256,
        march,
        ..RenderSettings::default()
    };
    render(&scene, &camera, &settings, &|_| {})
}

#[test]
fn russian_roulette_on_shadow_rays_saves_them_without_bias() {
    let image = |shadow_share| {
        fog_ball_at_256_spp(March {
            shadow_share,
            ..March::default()
        })
    };
    let (every, roulette) = (image(0.0), image(1.0));
    let total = |f: &super::Film| f.rgba.iter().map(|p| f64::from(p[1])).sum::<f64>();
    let (a, b) = (total(&every), total(&roulette));
    println!("green summed over the image: {a} with every shadow ray, {b} with roulette");
    assert!((a - b).abs() < 0.01 * a, "{a} vs {b}");
    let rays = |f: &super::Film| f.work().1;
    assert!(
        rays(&roulette) < 0.5 * rays(&every),
        "{} vs {}",
        rays(&roulette),
        rays(&every)
    );
    // Alpha does not depend on shadow rays at all.
    assert!(
        every
            .rgba
            .iter()
            .zip(&roulette.rgba)
            .all(|(p, q)| p[3] == q[3])
    );
}

/// Russian roulette on the rest of a view ray keeps radiance and alpha in expectation and
/// takes fewer samples: rays through a fog ball at 256 spp, marched to the cut-off against
/// rouletted from the first segment on (the most aggressive setting).
#[test]
fn russian_roulette_on_view_rays_saves_samples_without_bias() {
    let image = |view_share| {
        fog_ball_at_256_spp(March {
            view_share,
            ..March::default()
        })
    };
    let (every, roulette) = (image(0.0), image(1.0));
    for channel in [1, 3] {
        let total = |f: &super::Film| f.rgba.iter().map(|p| f64::from(p[channel])).sum::<f64>();
        let (a, b) = (total(&every), total(&roulette));
        println!("channel {channel} summed: {a} marching to the cut-off, {b} with roulette");
        assert!((a - b).abs() < 0.01 * a, "channel {channel}: {a} vs {b}");
    }
    let samples = |f: &super::Film| f.work().0;
    assert!(
        samples(&roulette) < 0.8 * samples(&every),
        "{} vs {}",
        samples(&roulette),
        samples(&every)
    );
}

/// Every hard case renders finite pixels with alpha in [0, 1].
fn assert_sane(scene: &Scene, camera: &Camera) -> super::Film {
    let f = render(scene, camera, &RenderSettings::default(), &|_| {});
    for p in &f.rgba {
        assert!(p.iter().all(|v| v.is_finite()), "{p:?}");
        assert!((0.0..=1.0).contains(&p[3]), "{p:?}");
    }
    f
}

#[test]
fn hard_cases_stay_finite_and_bounded() {
    let texel = || uniform_texel([8, 8, 8], 0.25, DVec3::new(-1.0, 0.0, -1.0), 2.0, [0.5; 3]);
    // Rays exactly along box faces and edges, axis-parallel: a camera on the box's face plane.
    let scene = Scene::new(
        DVec3::new(-1.0, 0.0, 6.0),
        vec![texel()],
        vec![look()],
        &[placed(DVec3::ZERO)],
        None,
        Lighting {
            sun: HEAD_ON,
            shading: Shading::default(),
            sky: None,
        },
    );
    let camera = Camera::look_at(scene.origin, DVec3::new(-1.0, 0.0, 0.0), 40.0, 16, 16).unwrap();
    let f = assert_sane(&scene, &camera);
    assert!(f.rgba.iter().any(|p| p[3] > 0.1), "the box is seen");
    // The camera inside a texel.
    let scene = Scene {
        origin: DVec3::new(0.0, 1.0, 0.0),
        ..Scene::new(
            DVec3::new(0.0, 1.0, 0.0),
            vec![texel()],
            vec![look()],
            &[placed(DVec3::ZERO)],
            None,
            Lighting {
                sun: HEAD_ON,
                shading: Shading::default(),
                sky: None,
            },
        )
    };
    let camera = Camera::look_at(scene.origin, DVec3::new(0.0, 1.0, -5.0), 60.0, 16, 16).unwrap();
    let f = assert_sane(&scene, &camera);
    let centre = f.rgba[8 + 16 * 8];
    assert!(
        (centre[3] - (1.0 - (-2.0f32 * 1.0).exp())).abs() < 0.02,
        "inside: {centre:?}"
    );
    // Extinction from 1e-8 to 1e6 per metre; the sun at the zenith and at the horizon.
    for sigma in [1e-8, 1.0, 1e6] {
        for elevation in [90.0, 0.0] {
            let t = uniform_texel(
                [8, 8, 8],
                0.25,
                DVec3::new(-1.0, 0.0, -1.0),
                sigma,
                [0.5; 3],
            );
            let scene = one_box_over_ground(t, elevation);
            let camera =
                Camera::look_at(scene.origin, DVec3::new(0.0, 0.5, 0.0), 50.0, 12, 12).unwrap();
            assert_sane(&scene, &camera);
        }
    }
}

/// Texture `t` placed once at the origin over a ground 20 m across, the sun at `elevation`
/// degrees, seen from 6 m away.
fn one_box_over_ground(t: Texel, elevation: f64) -> Scene {
    Scene::new(
        DVec3::new(0.3, 1.0, 6.0),
        vec![t],
        vec![look()],
        &[placed(DVec3::ZERO)],
        Some(ground(0.0, 20.0, 0.3)),
        Lighting {
            sun: Sun::from_angles(30.0, elevation, std::f32::consts::PI),
            shading: Shading::default(),
            sky: None,
        },
    )
}

/// One dense cell in an empty 8³ box over a lit ground, its density `density` and the
/// texture's extinction scale `scale`, rendered at 16 x 16 with sun shadows `shadows`.
fn one_dense_cell(density: f32, scale: f64, shadows: ShadowRays) -> super::Film {
    let mut l = Level::empty([8, 8, 8], 0.25);
    let i = l.index(4, 4, 4);
    l.density[1][i] = density;
    l.albedo[1][i] = [0.3, 0.6, 0.2];
    l.gradient[1] = sobel::gradient(&l.density[1], l.dims, 0.25);
    let mut t = uniform_texel([8, 8, 8], 0.25, DVec3::new(-1.0, 0.0, -1.0), 0.0, [0.5; 3]);
    t.levels = mip_chain(l, scale);
    t.info.extinction_scale = scale;
    let scene = one_box_over_ground(t, 40.0);
    let camera = Camera::look_at(scene.origin, DVec3::new(0.0, 1.0, 0.0), 30.0, 16, 16).unwrap();
    let settings = RenderSettings {
        spp: 4,
        // The finest level alone: a coarse cell of a scale beyond f32's range, one dense child
        // in eight, has a density below f32's smallest.
        march: March {
            shadows,
            shadow_lod: 0.0,
            ..March::default()
        },
        ..RenderSettings::default()
    };
    render(&scene, &camera, &settings, &|_| {})
}

#[test]
fn extinction_beyond_f32_renders_as_an_opaque_one_does() {
    // A valid file's extinction scale may lie beyond f32's range, and its densities anywhere
    // in f32's: both are opaque, and must draw as a merely huge extinction (1e30 per metre
    // for a cell 0.25 m wide) does, not black where infinity met a zero weight.
    for shadows in [ShadowRays::Cached, ShadowRays::Exact] {
        let opaque = one_dense_cell(1.0, 1e30, shadows);
        assert!(
            opaque.rgba.iter().any(|p| p[3] > 0.5),
            "{shadows:?}: the cell is seen"
        );
        for (density, scale) in [(1.0, 1e300), (f32::MAX, 1.0), (f32::MAX, 1e300)] {
            let f = one_dense_cell(density, scale, shadows);
            for (k, (p, q)) in f.rgba.iter().zip(&opaque.rgba).enumerate() {
                assert!(
                    p.iter().zip(q).all(|(a, b)| (a - b).abs() <= 0.02),
                    "{shadows:?}, density {density:e}, scale {scale:e}, pixel {k}: \
                     {p:?} where 1e30 per metre gives {q:?}"
                );
            }
        }
    }
}

#[test]
fn ten_thousand_boxes_overlapping_one_point_add_up() {
    // 10,000 faint copies of one box on the same spot: together they are one box of 10,000
    // times the extinction.
    let sigma = 1e-4f32;
    let texel = uniform_texel(
        [4, 4, 4],
        0.5,
        DVec3::new(-1.0, -1.0, -1.0),
        sigma,
        [0.5; 3],
    );
    let placed: Vec<Placed> = (0..10_000)
        .map(|i| Placed {
            rotation: (i % 4) as f32 * std::f32::consts::FRAC_PI_2,
            ..placed(DVec3::ZERO)
        })
        .collect();
    let scene = Scene::new(
        DVec3::new(0.0, 0.0, 10.0),
        vec![texel],
        vec![look()],
        &placed,
        None,
        Lighting {
            sun: HEAD_ON,
            shading: PLAIN,
            sky: None,
        },
    );
    let t = transmittance(
        &scene,
        Ray {
            origin: Vec3::new(0.0, 0.0, 5.0),
            dir: Vec3::NEG_Z,
        },
        f32::INFINITY,
        &March {
            cutoff: 0.0,
            ..March::default()
        },
        &Caster {
            footprint: 0.0,
            key: 1,
            own: &[],
            draw: &Draw::Texel,
        },
    );
    let want = (-sigma * 10_000.0 * 2.0).exp();
    assert!((t - want).abs() < 1e-3, "{t} vs {want}");
}

#[test]
fn adjacent_boxes_leave_no_crack() {
    // Two unit-density boxes side by side along the ray transmit as one box twice as long,
    // also when the ray runs exactly along their shared face.
    let texel = uniform_texel([4, 4, 4], 0.5, DVec3::new(-1.0, -1.0, -1.0), 0.5, [0.5; 3]);
    let scene = Scene::new(
        DVec3::new(0.0, 0.0, 10.0),
        vec![texel],
        vec![look()],
        &[
            placed(DVec3::new(0.0, 0.0, 1.0)),
            placed(DVec3::new(0.0, 0.0, -1.0)),
        ],
        None,
        Lighting {
            sun: HEAD_ON,
            shading: PLAIN,
            sky: None,
        },
    );
    for x in [0.3f32, 1.0] {
        let t = transmittance(
            &scene,
            Ray {
                origin: Vec3::new(x, 0.0, 0.0),
                dir: Vec3::NEG_Z,
            },
            f32::INFINITY,
            &March {
                cutoff: 0.0,
                ..March::default()
            },
            &Caster {
                footprint: 0.0,
                key: 1,
                own: &[],
                draw: &Draw::Texel,
            },
        );
        let want = (-0.5f32 * 4.0).exp();
        assert!((t - want).abs() < 1e-4, "x {x}: {t} vs {want}");
    }
}

#[test]
fn zero_density_gradients_shade_without_a_normal() {
    // A huge uniform box seen from inside: no gradient anywhere near the ray.
    let texel = uniform_texel([8, 8, 8], 2.0, DVec3::splat(-8.0), 0.3, [0.5; 3]);
    let scene = Scene::new(
        DVec3::ZERO,
        vec![texel],
        vec![look()],
        &[placed(DVec3::ZERO)],
        None,
        Lighting {
            sun: HEAD_ON,
            shading: PLAIN,
            sky: None,
        },
    );
    let r = radiance(&scene, Vec3::X, 0.0, 1, &March::default());
    assert!(r.rgb.is_finite() && r.rgb.x > 0.0, "{:?}", r.rgb);
}

#[test]
fn a_terrain_a_hundred_kilometres_away_renders_as_one_at_the_origin() {
    let far = DVec3::new(100_000.0, 0.0, -100_000.0);
    let shot = |offset: DVec3| {
        let texel = uniform_texel(
            [8, 8, 8],
            0.5,
            DVec3::new(-2.0, 0.0, -2.0),
            1.5,
            [0.3, 0.5, 0.2],
        );
        let mut g = ground(0.0, 30.0, 0.35);
        for p in &mut g.positions {
            *p = (p.as_dvec3() + offset).as_vec3();
        }
        let scene = Scene::new(
            offset + DVec3::new(0.0, 6.0, 12.0),
            vec![texel],
            vec![look()],
            &[placed(offset)],
            Some(g),
            Lighting {
                sun: Sun::from_angles(220.0, 35.0, std::f32::consts::PI),
                shading: Shading::default(),
                sky: None,
            },
        );
        let camera = Camera::look_at(
            scene.origin,
            offset + DVec3::new(0.0, 1.5, 0.0),
            50.0,
            20,
            16,
        )
        .unwrap();
        assert_sane(&scene, &camera)
    };
    let (near, away) = (shot(DVec3::ZERO), shot(far));
    let worst = near
        .rgba
        .iter()
        .zip(&away.rgba)
        .map(|(a, b)| (0..4).map(|c| (a[c] - b[c]).abs()).fold(0.0, f32::max))
        .fold(0.0, f32::max);
    // Vertex positions are f32 in the glTF: 100 km away they carry 8 mm steps.
    assert!(worst < 0.02, "{worst}");
}

/// Two boxes over a ground quad, seen at an angle: edges against the sky and the ground.
fn two_boxes_over_ground() -> (Scene, Camera) {
    let texel = uniform_texel(
        [8, 8, 8],
        0.5,
        DVec3::new(-2.0, 0.0, -2.0),
        1.0,
        [0.3, 0.5, 0.2],
    );
    let scene = Scene::new(
        DVec3::new(1.0, 5.0, 12.0),
        vec![texel],
        vec![look()],
        &[placed(DVec3::ZERO), placed(DVec3::new(3.0, 0.0, -2.0))],
        Some(ground(0.0, 30.0, 0.35)),
        Lighting {
            sun: Sun::from_angles(220.0, 35.0, std::f32::consts::PI),
            shading: Shading::default(),
            sky: None,
        },
    );
    let camera = Camera::look_at(scene.origin, DVec3::new(0.5, 1.5, 0.0), 50.0, 70, 45).unwrap();
    (scene, camera)
}

#[test]
fn the_image_is_the_same_for_any_thread_count_and_a_crop_equals_its_region() {
    let (scene, camera) = two_boxes_over_ground();
    // With edges sampled again too: a crop's border pixels compare with pixels outside it.
    for edges in [
        None,
        Some(Edges {
            spp: 4,
            contrast: 0.05,
            colour: true,
        }),
    ] {
        let settings = RenderSettings {
            spp: 2,
            edges,
            ..RenderSettings::default()
        };
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| render(&scene, &camera, &settings, &|_| {}));
        let two = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap()
            .install(|| render(&scene, &camera, &settings, &|_| {}));
        assert_eq!(one, two);
        let crop = render(
            &scene,
            &camera,
            &RenderSettings {
                crop: Some([13, 7, 50, 40]),
                ..settings
            },
            &|_| {},
        );
        for y in 7..40 {
            for x in 13..50 {
                let a = crop.rgba[(x - 13) + crop.width as usize * (y - 7)];
                let b = one.rgba[x + one.width as usize * y];
                assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "pixel {x},{y}");
            }
        }
    }
}

/// With `edges`, a pixel that differs from a neighbour in the first pass is the pixel a
/// render at the edges' count makes, bit for bit, and every other pixel the first pass's;
/// the work of both passes counts.
#[test]
fn pixels_at_edges_are_rendered_again_at_the_edges_count() {
    let (scene, camera) = two_boxes_over_ground();
    let at = |spp: u32, edges: Option<Edges>| {
        let settings = RenderSettings {
            spp,
            edges,
            ..RenderSettings::default()
        };
        render(&scene, &camera, &settings, &|_| {})
    };
    let edges = Edges {
        spp: 9,
        contrast: 0.05,
        colour: true,
    };
    let (first, more, both) = (at(1, None), at(9, None), at(1, Some(edges)));
    let width = first.width;
    let marked = edges.find([0, 0, width, first.height], first.frame, |x, y| {
        first.rgba[(x + width * y) as usize]
    });
    let again = marked.iter().filter(|&&m| m).count();
    assert!(
        again > 20 && again < marked.len() / 2,
        "{again} of {}",
        marked.len()
    );
    assert_eq!(both.sampled_again, again as u64);
    for (i, &m) in marked.iter().enumerate() {
        let expected = if m { &more } else { &first };
        let bits = |f: &super::Film| f.rgba[i].map(f32::to_bits);
        assert_eq!(bits(&both), bits(expected), "pixel {i}, at an edge: {m}");
        let work = first.samples[i] + if m { more.samples[i] } else { 0.0 };
        assert_eq!(both.samples[i], work, "pixel {i}");
    }
    let total = |f: &super::Film| f.work().0 * f.rgba.len() as f64;
    let again_work: f64 = (0..marked.len())
        .filter(|&i| marked[i])
        .map(|i| f64::from(more.samples[i]))
        .sum();
    // `work` is a mean: its sum, taken back, is exact only to a rounding.
    let expected = total(&first) + again_work;
    assert!(
        (total(&both) - expected).abs() < 1e-9 * expected,
        "{expected}"
    );
}

/// A leaf-normal moment turns with its instance: the moment of a turned normal is the turned
/// moment.
#[test]
fn leaf_moments_turn_with_the_instance() {
    let n = Vec3::new(0.3, -0.5, 0.81).normalize();
    let moment = crate::volume::normal_moment;
    for angle in [0.0f32, 0.7, 2.0, -2.9] {
        let (sin, cos) = angle.sin_cos();
        let inst = super::instances::TreeTransform {
            look: 0,
            model: 0,
            position: Vec3::ZERO,
            cos,
            sin,
            scale: 1.0,
        };
        let want = moment(inst.dir_to_world(n));
        let got = super::integrate::turn_moment(moment(n), cos, sin);
        for k in 0..6 {
            assert!(
                (got[k] - want[k]).abs() < 1e-6,
                "{angle}: {got:?} vs {want:?}"
            );
        }
    }
}

/// A dense slab of foliage (4 m x 4 m x 1 m, facing +z) whose every cell holds leaves of the
/// moment `leaves` and self-shadowing `factor`, seen head-on from +z, lit by `sun` (irradiance
/// pi, so that a white Lambertian surface facing it has radiance 1); foliage albedo 0.5.
fn foliage_slab(leaves: [f32; 6], factor: f32, sun: Vec3, shadows: bool) -> Scene {
    let mut texel = uniform_texel(
        [16, 16, 4],
        0.25,
        DVec3::new(-2.0, -2.0, -1.0),
        40.0,
        [0.5; 3],
    );
    for l in &mut texel.levels {
        l.density.swap(0, 1);
        l.gradient.swap(0, 1);
        l.albedo.swap(0, 1);
        l.leaves = vec![leaves; l.cell_count()];
        l.self_shadow = SelfShadow::uniform([factor; 6]);
    }
    let mut scene = Scene::new(
        DVec3::new(0.0, 0.0, 10.0),
        vec![texel],
        vec![look()],
        &[placed(DVec3::ZERO)],
        None,
        Lighting {
            sun: Sun {
                direction: sun.normalize(),
                irradiance: std::f32::consts::PI,
            },
            shading: PLAIN,
            sky: None,
        },
    );
    scene.shadows = shadows;
    scene
}

/// The mean radiance (green) over many rays into the middle of `scene`'s slab.
fn slab_radiance(scene: &Scene) -> f64 {
    let n = 4000u64;
    let sum: f64 = (0..n)
        .map(|k| {
            let u = rng::unit(rng::hash3(k, 1, 0x51ab)) as f32 - 0.5;
            let v = rng::unit(rng::hash3(k, 2, 0x51ab)) as f32 - 0.5;
            let dir = Vec3::new(u * 0.1, v * 0.1, -1.0).normalize();
            f64::from(radiance(scene, dir, 0.0, k, &March::default()).rgb[1])
        })
        .sum();
    sum / n as f64
}

/// Foliage shades as a cloud of two-sided, opaque, diffuse leaves, against the closed forms of
/// the area scattering phase function (Shultis and Myneni 1988), unshadowed so that only the
/// phase function shows: leaves facing every way, at several angles between eye and sun;
/// leaves all facing the eye (horizontal leaves seen from above) lit head-on, at 60 degrees,
/// from the side and from behind (through the leaf: dark).
#[test]
fn foliage_shades_as_a_cloud_of_leaves_in_closed_form() {
    let albedo = 0.5;
    for g in [0.0f32, 0.6, 1.2, 2.0] {
        let scene = foliage_slab(
            ISOTROPIC_LEAVES,
            1.0,
            Vec3::new(g.sin(), 0.0, g.cos()),
            false,
        );
        let g = f64::from(g);
        let want = albedo
            * (2.0 / (3.0 * std::f64::consts::PI) * (g.sin() - g * g.cos()) + 2.0 / 3.0 * g.cos());
        let got = slab_radiance(&scene);
        assert!(
            (got - want).abs() < 0.01,
            "isotropic, angle {g}: {got} vs {want}"
        );
    }
    // Leaves all facing the eye (normals +-z: horizontal leaves seen from above, the slab's +z
    // standing for up): lit head-on, the full Lambert response; at 60 degrees, its cosine;
    // from the side, nothing; from behind (through the leaf: opaque), nothing.
    let facing = [0.0, 0.0, 1.0, 0.0, 0.0, 0.0];
    let lit = |sun: Vec3| slab_radiance(&foliage_slab(facing, 1.0, sun, false));
    let front = lit(Vec3::Z);
    assert!(
        (front - albedo).abs() < 0.01,
        "facing, lit head-on: {front}"
    );
    let (s60, c60) = 60f32.to_radians().sin_cos();
    let slanted = lit(Vec3::new(0.0, s60, c60));
    assert!(
        (slanted - 0.5 * albedo).abs() < 0.01,
        "facing, lit at 60 degrees: {slanted}"
    );
    let side = lit(Vec3::X);
    assert!(side < 0.05 * albedo, "facing, lit from the side: {side}");
    let behind = lit(Vec3::new(0.0, 0.3, -1.0));
    assert!(behind < 0.01 * albedo, "facing, lit from behind: {behind}");
}

/// A leaf's shadow ray crosses its own tree with the level's self-shadowing factor: 0 lets a
/// dense slab light every leaf the eye sees, as if unshadowed (the hot spot); 1 is the
/// independent medium, darker.
#[test]
fn the_self_shadowing_factor_scales_a_leafs_own_shadow() {
    let sun = Vec3::new(0.5, 0.0, 1.0);
    let unshadowed = slab_radiance(&foliage_slab(ISOTROPIC_LEAVES, 1.0, sun, false));
    let none = slab_radiance(&foliage_slab(ISOTROPIC_LEAVES, 0.0, sun, true));
    let independent = slab_radiance(&foliage_slab(ISOTROPIC_LEAVES, 1.0, sun, true));
    assert!((none - unshadowed).abs() < 1e-9, "{none} vs {unshadowed}");
    assert!(
        independent < 0.7 * unshadowed,
        "{independent} vs {unshadowed}"
    );
}

/// The canopy layer is a matte: the trees' opacity averaged over the pixel's samples, so a
/// pixel half over an opaque slab's edge holds about a half (not the first sample's 0 or 1).
#[test]
fn the_canopy_layer_averages_the_samples() {
    let texel = uniform_texel(
        [16, 16, 4],
        0.25,
        DVec3::new(-2.0, -2.0, -1.0),
        200.0,
        [0.5; 3],
    );
    let scene = Scene::new(
        DVec3::new(2.0, 0.0, 10.0),
        vec![texel],
        vec![look()],
        &[placed(DVec3::ZERO)],
        None,
        Lighting {
            sun: HEAD_ON,
            shading: PLAIN,
            sky: None,
        },
    );
    let camera = Camera::look_at(scene.origin, DVec3::new(2.0, 0.0, 0.0), 5.0, 1, 1).unwrap();
    let film = render(
        &scene,
        &camera,
        &RenderSettings {
            spp: 64,
            ..RenderSettings::default()
        },
        &|_| {},
    );
    let (canopy, alpha) = (film.canopy[0], film.rgba[0][3]);
    assert!((canopy - 0.5).abs() < 0.1, "{canopy}");
    assert!((canopy - alpha).abs() < 1e-6, "{canopy} vs {alpha}");
}

/// Shadow rays read from the cached depths (`render::sun_depth`) what an exact march finds:
/// three overlapping trees of a lopsided cloud, turned and scaled, lit from the side; from
/// points in and around them, with and without their own trees' self-shadowing, at the finest
/// level and one coarser. The exact march here takes 20 samples per cell, so its own noise
/// (and the bias exp(-depth) takes from it) is far below the tolerance. The trees stand at
/// turns the grids of every level read here are drawn at (16ths), so this measures the grids
/// alone: interpolated between columns, single rays' light is off by 0.019-0.035 over these
/// three sets of turns, the mean light by less than 0.001 (0.0008-0.0012 dark when the
/// lookup interpolated depths alone; the mean depth, which the lookup no longer keeps where
/// it interpolates transmittances, reads 0.008 shallow on the first set).
#[test]
fn cached_shadow_rays_find_the_transmittance_an_exact_march_finds() {
    let turn = std::f32::consts::TAU / 16.0;
    for turns in [[1.0, 5.0, 13.0], [2.0, 6.0, 13.0], [0.0, 3.0, 9.0]] {
        let (worst, bias) = cached_against_exact(turns.map(|k| k * turn));
        assert!(
            worst < 0.05,
            "{turns:?}: worst difference in transmittance {worst}"
        );
        assert!(bias.iter().all(|b| b.abs() < 0.001), "{turns:?}: {bias:?}");
    }
}

/// The same trees at turns between the grids': rounding each tree's shadow to the nearest
/// 64th of a turn (on the finest level; 32nds one coarser) shifts it by up to a third of a
/// cell here, which moves single rays' light by up to 0.13 but leaves the mean light within
/// 0.0025 of the exact march's (`make budget`: 0.3-0.6% more error over a frame).
#[test]
fn cached_shadow_rays_of_trees_between_turns_stay_near_the_exact_march() {
    let (worst, bias) = cached_against_exact([0.4, 2.2, 5.1]);
    assert!(worst < 0.15, "worst difference in transmittance {worst}");
    assert!(bias.iter().all(|b| b.abs() < 0.004), "{bias:?}");
}

/// Over points in and around three trees at `rotations` (radians): the largest difference in
/// transmittance between cached and exact shadow rays, and per footprint (the other trees read
/// at level 1, at level 2) the mean difference in transmittance, cached less exact.
fn cached_against_exact(rotations: [f32; 3]) -> (f32, [f64; 2]) {
    let n = 16;
    let mut l = Level::empty([n; 3], 0.25);
    for i in 0..l.cell_count() {
        let c = [i % n, (i / n) % n, i / (n * n)].map(|v| (v as f32 + 0.5) / n as f32);
        let lump = |x: f32, y: f32, z: f32, r: f32| {
            let d = ((c[0] - x).powi(2) + (c[1] - y).powi(2) + (c[2] - z).powi(2)).sqrt();
            (1.0 - d / r).max(0.0)
        };
        l.density[1][i] = 3.0 * lump(0.4, 0.55, 0.5, 0.45) + 8.0 * lump(0.7, 0.3, 0.3, 0.2);
        l.density[0][i] = 6.0 * lump(0.5, 0.3, 0.5, 0.15);
    }
    let mut texel = uniform_texel([n; 3], 0.25, DVec3::new(-2.0, 0.0, -2.0), 0.0, [0.5; 3]);
    texel.levels = mip_chain(l, 1.0);
    let trees = [
        (DVec3::ZERO, rotations[0], 1.0),
        (DVec3::new(1.5, 0.3, -0.8), rotations[1], 1.3),
        (DVec3::new(-0.6, -0.2, 1.2), rotations[2], 0.8),
    ];
    let placed: Vec<Placed> = trees
        .iter()
        .map(|&(position, rotation, scale)| Placed {
            look: 0,
            position,
            rotation,
            scale,
        })
        .collect();
    let scene = Scene::new(
        DVec3::new(0.0, 1.0, 0.0),
        vec![texel],
        vec![Look {
            foliage: 0.8,
            ..look()
        }],
        &placed,
        None,
        Lighting {
            sun: Sun::from_angles(250.0, 35.0, std::f32::consts::PI),
            shading: PLAIN,
            sky: None,
        },
    );
    let mut s = rng::Stream::new(11, 0);
    let mut worst = 0.0f32;
    let mut bias = [0.0f64; 2];
    for k in 0..400u64 {
        let origin = Vec3::new(
            s.unit() as f32 * 5.0 - 2.5,
            s.unit() as f32 * 4.0 - 1.5,
            s.unit() as f32 * 5.0 - 2.5,
        );
        let ray = Ray {
            origin,
            dir: scene.sun.direction,
        };
        // Every other point lies in its trees as a leaf would, with their self-shadowing.
        let inside: Vec<OwnTree> = (0..3u32)
            .filter(|&i| {
                let local = scene.instances.get(i).to_model(origin);
                k % 2 == 0
                    && scene
                        .instances
                        .local_interval(
                            i,
                            &Ray {
                                origin: local,
                                dir: Vec3::Y,
                            },
                            0.0,
                        )
                        .is_some()
            })
            .map(|i| OwnTree {
                instance: i,
                level: (k % 2) as usize,
                factor: 0.6,
                exact: false,
            })
            .collect();
        let footprint = if k % 4 < 2 { 0.0 } else { 0.6 };
        let t = |shadows, step| {
            transmittance(
                &scene,
                ray,
                f32::INFINITY,
                &March {
                    step,
                    cutoff: 0.0,
                    shadows,
                    ..March::default()
                },
                &Caster {
                    footprint,
                    key: k,
                    own: &inside,
                    draw: &Draw::Texel,
                },
            )
        };
        let (cached, exact) = (t(ShadowRays::Cached, 1.0), t(ShadowRays::Exact, 0.05));
        bias[(k % 4 / 2) as usize] += f64::from(cached - exact);
        worst = worst.max((cached - exact).abs());
    }
    (worst, bias.map(|b| b / 200.0))
}

/// A grid shared by trees of one turn and different scales, and species that differ only in
/// colour, is the same whichever of them asks for it first (the sun is turned without the tree's scale): otherwise the image would
/// depend on which thread reached which tree first.
#[test]
fn a_shared_sun_depth_grid_does_not_depend_on_the_tree_that_built_it() {
    let mut texel = uniform_texel([8; 3], 0.5, DVec3::new(-2.0, 0.0, -2.0), 1.0, [0.5; 3]);
    let mut s = rng::Stream::new(5, 0);
    for d in texel.levels[0].density[1].iter_mut() {
        *d = 4.0 * s.unit() as f32;
    }
    let scales = [1.0, 1.37, 0.73, 1.91, 2.3, 0.61, 1.13, 0.87];
    // Half of them of a second species that differs only in colour: it shares their grids.
    let placed: Vec<Placed> = (0..scales.len())
        .map(|i| Placed {
            look: (i % 2) as u16,
            position: DVec3::new(5.0 * i as f64, 0.0, 0.0),
            rotation: 0.9,
            scale: scales[i],
        })
        .collect();
    let scene = || {
        Scene::new(
            DVec3::ZERO,
            vec![texel.clone()],
            vec![
                look(),
                Look {
                    foliage_albedo: Vec3::new(0.3, 0.1, 0.05),
                    ..look()
                },
            ],
            &placed,
            None,
            Lighting {
                sun: Sun::from_angles(200.0, 40.0, std::f32::consts::PI),
                shading: PLAIN,
                sky: None,
            },
        )
    };
    let depths = |order: Vec<u32>| {
        let scene = scene();
        let mut d = vec![0.0f32; scales.len()];
        for i in order {
            let origin = scene.instances.get(i).position + Vec3::new(0.3, 1.0, -0.2);
            let ray = Ray {
                origin,
                dir: scene.sun.direction,
            };
            d[i as usize] = scene.sun_depth.depth(&scene, i, 0, &ray, 1.0);
        }
        assert_eq!(
            scene.sun_depth.built().0,
            1,
            "one grid for one turn and two species of one shadow"
        );
        d.iter().map(|d| d.to_bits()).collect::<Vec<_>>()
    };
    let first = |i: u32| {
        let n = scales.len() as u32;
        depths((0..n).map(|k| (i + k) % n).collect())
    };
    for i in 1..scales.len() as u32 {
        assert_eq!(first(0), first(i), "tree {i} first");
    }
}

/// Wood shades as a surface whatever the sun's angle: an opaque slab seen head-on and lit from
/// 0 to 75 degrees off its normal gives Lambert's albedo x cos, averaged over rays (the sample
/// lies somewhere in its cell, and its shadow ray must leave the slab's surface layer, which
/// towards a sun at angle theta takes the layer's thickness over cos theta, not one layer).
#[test]
fn an_opaque_slab_lit_from_any_angle_gives_the_lambert_radiance_on_average() {
    for degrees in [0.0f32, 30.0, 60.0, 75.0] {
        let angle = degrees.to_radians();
        let scene = opaque_slab(Sun {
            direction: Vec3::new(0.0, angle.sin(), angle.cos()),
            irradiance: std::f32::consts::PI,
        });
        let rays = 1000;
        let mean = (0..rays)
            .map(|key| f64::from(radiance(&scene, Vec3::NEG_Z, 0.0, key, &March::default()).rgb[0]))
            .sum::<f64>()
            / rays as f64;
        let want = f64::from(SLAB_ALBEDO[0] * angle.cos());
        assert!(
            (mean - want).abs() < 0.01 * want,
            "sun {degrees} degrees off the normal: {mean} against {want}"
        );
    }
}

/// A film keeps only the layers it is asked to (the rest would be memory no file carries), and
/// the file it encodes with them is the same bytes as a film that kept every layer writes; the
/// work it reports is the same; a layer it did not keep is refused by name, not read as zeros.
#[test]
fn a_film_keeps_only_the_layers_its_file_carries() {
    use super::Aovs;
    let (scene, camera) = fog_ball();
    let film = |layers| {
        render(
            &scene,
            &camera,
            &RenderSettings {
                spp: 4,
                layers,
                ..RenderSettings::default()
            },
            &|_| {},
        )
    };
    let all = film(Aovs::ALL);
    let matrices = (camera.world_to_camera(), camera.world_to_ndc());
    let exr = |f: &super::Film, aovs| f.exr_bytes(false, aovs, matrices.0, matrices.1, None);
    for aovs in [
        Aovs::default(),
        Aovs {
            canopy: true,
            ..Aovs::default()
        },
        Aovs {
            lod: true,
            samples: true,
            ..Aovs::default()
        },
        Aovs::ALL,
    ] {
        let kept = film(aovs);
        assert_eq!(kept.work(), all.work());
        assert_eq!(
            exr(&kept, aovs).unwrap().bytes,
            exr(&all, aovs).unwrap().bytes,
            "{aovs:?}"
        );
    }
    let bare = film(Aovs::default());
    assert!(bare.normal.is_empty() && bare.samples.is_empty() && bare.canopy.is_empty());
    let asked = Aovs {
        normal: true,
        ..Aovs::default()
    };
    let refused = exr(&bare, asked)
        .err()
        .expect("a layer the film did not keep");
    assert!(refused.contains("normal"), "{refused}");
}

/// A texture holding only a solid: a ball of `radius` metres at the model's origin, its
/// cells' inside fractions box-filtered (as `bake::solid` measures them), of wood of colour
/// [`SLAB_ALBEDO`], in a grid of 16 cells of a quarter metre.
fn solid_ball(radius: f64) -> Texel {
    let (n, cell) = (16usize, 0.25f64);
    let origin = DVec3::splat(-2.0);
    let mut t = uniform_texel([n; 3], cell, origin, 0.0, SLAB_ALBEDO);
    let l = &mut t.levels[0];
    let m = 8;
    let mut solid = vec![0.0f32; n * n * n];
    for (i, s) in solid.iter_mut().enumerate() {
        let at = DVec3::new((i % n) as f64, (i / n % n) as f64, (i / (n * n)) as f64);
        let inside = (0..m * m * m)
            .filter(|k| {
                let sub = DVec3::new((k % m) as f64, (k / m % m) as f64, (k / (m * m)) as f64);
                let p = origin + (at + (sub + 0.5) / m as f64) * cell;
                p.length() < radius
            })
            .count();
        *s = inside as f32 / (m * m * m) as f32;
    }
    l.solid = [solid, vec![0.0; n * n * n]];
    t.levels = mip_chain(l.clone(), 1.0);
    t
}

/// A texture's solid is an opaque surface where the box-filtered inside crosses a half: a
/// ball seen head-on, lit from 0, 40 and 80 degrees off the line of sight, is where the
/// sphere is (hit distance within a fifth of a cell), faces as it does (normals within 8
/// degrees) and is as bright as Lambert's law makes the sphere (within 2 % of the albedo on
/// average over the disc), with exact shadow rays and with cached ones: the ball does not
/// shadow its own lit side.
#[test]
fn a_solid_ball_shades_as_the_sphere_it_holds() {
    let radius = 1.3f32;
    let eye = Vec3::new(0.0, 0.0, 10.0);
    for degrees in [0.0f32, 40.0, 80.0] {
        let a = degrees.to_radians();
        let sun = Sun {
            direction: Vec3::new(a.sin(), 0.0, a.cos()),
            irradiance: std::f32::consts::PI,
        };
        let scene = lone_scene(solid_ball(f64::from(radius)), eye.as_dvec3(), sun);
        for shadows in [ShadowRays::Exact, ShadowRays::Cached] {
            let march = March {
                shadows,
                ..March::default()
            };
            let (mut error, mut count) = (0.0f64, 0);
            for (k, (i, j)) in (0..15)
                .flat_map(|i| (0..15).map(move |j| (i, j)))
                .enumerate()
            {
                let target = Vec3::new(i as f32 - 7.0, j as f32 - 7.0, 0.0) * (0.8 * radius / 7.0);
                if target.length() > 0.8 * radius {
                    continue;
                }
                let dir = (target - eye).normalize();
                // The ray from the eye (the frame's origin) meets the sphere about `-eye`.
                let b = dir.dot(eye);
                let t = -b - (b * b - eye.length_squared() + radius * radius).sqrt();
                let normal = (eye + dir * t).normalize();
                let r = radiance(&scene, dir, 0.0, k as u64, &march);
                assert!(r.transmittance == 0.0, "{degrees}: the ray went through");
                assert!(
                    (r.distance - t).abs() < 0.05,
                    "{degrees}: hit at {} against {t}",
                    r.distance
                );
                assert!(
                    r.normal.dot(normal) > 8f32.to_radians().cos(),
                    "{degrees}: normal {} against {normal}",
                    r.normal
                );
                let want = SLAB_ALBEDO[0] * normal.dot(sun.direction).max(0.0);
                error += f64::from(r.rgb[0] - want);
                count += 1;
            }
            let bias = error / f64::from(count);
            assert!(
                bias.abs() < 0.02 * f64::from(SLAB_ALBEDO[0]),
                "sun {degrees} degrees off, {shadows:?} shadows: mean error {bias}"
            );
        }
    }
}

/// A solid's shadow is sharp: behind a ball lit obliquely, a point's shadow ray through
/// cached depths (the grid's map of where each column enters a solid) and through an exact
/// march both find the light stopped exactly where the ray meets the sphere and whole where
/// it passes by, everywhere but within half a cell of the shadow's edge (where the cached
/// lookup blends the four columns around it, half a cell apart here).
#[test]
fn a_solids_shadow_is_the_spheres_cached_or_exact() {
    let radius = 1.3f32;
    let eye = Vec3::new(0.0, 0.0, 10.0);
    let sun = Sun {
        direction: Vec3::new(0.3, 0.2, 1.0).normalize(),
        irradiance: std::f32::consts::PI,
    };
    let scene = lone_scene(solid_ball(f64::from(radius)), eye.as_dvec3(), sun);
    let mut checked = 0;
    for (k, (i, j)) in (0..25)
        .flat_map(|i| (0..25).map(move |j| (i, j)))
        .enumerate()
    {
        let p = Vec3::new(i as f32 * 0.2 - 2.4, j as f32 * 0.2 - 2.4, -2.6);
        // The ray from p towards the sun passes the ball's centre at this distance.
        let along = (-p).dot(sun.direction);
        let miss = (-p - sun.direction * along).length();
        if (miss - radius).abs() < 0.13 || along < 0.0 {
            continue;
        }
        let want = if miss < radius { 0.0 } else { 1.0 };
        for shadows in [ShadowRays::Cached, ShadowRays::Exact] {
            let got = transmittance(
                &scene,
                Ray {
                    origin: p - eye,
                    dir: sun.direction,
                },
                f32::INFINITY,
                &March {
                    shadows,
                    ..March::default()
                },
                &Caster {
                    footprint: 0.0,
                    key: k as u64,
                    own: &[],
                    draw: &Draw::Texel,
                },
            );
            assert!(
                (got - want).abs() < 1e-3,
                "{shadows:?}: {p} passes the centre at {miss}: light {got}"
            );
        }
        checked += 1;
    }
    assert!(checked > 300, "{checked}");
}

/// `solid_ball(radius)` with wood of extinction `sigma` in the cells whose centres lie
/// between `from` and `to` metres outside the sphere (a rim on its surface, or a shell off
/// it) and beyond `x_min` along x.
fn ball_with_shell(radius: f64, (from, to): (f64, f64), x_min: f64, sigma: f32) -> Texel {
    let mut t = solid_ball(radius);
    let mut l = t.levels[0].clone();
    let (dims, cell, origin) = (l.dims, l.cell, DVec3::from(t.info.origin));
    for (i, d) in l.density[0].iter_mut().enumerate() {
        let at = DVec3::new(
            (i % dims[0]) as f64,
            (i / dims[0] % dims[1]) as f64,
            (i / (dims[0] * dims[1])) as f64,
        );
        let p = origin + (at + 0.5) * cell;
        let out = p.length() - radius;
        if out > from && out < to && p.x > x_min {
            *d = sigma;
        }
    }
    l.gradient[0] = sobel::gradient(&l.density[0], dims, cell);
    t.levels = mip_chain(l, 1.0);
    t
}

/// What a solid's level set leaves out as density (a rim thinner than a cell) lies on the
/// solid's surface and does not shadow it: a ray leaving the ball's lit side towards the
/// sun through its own tree passes the first cell's density as it passes the solid there;
/// the same density a shell two cells off the surface still stops. (Rims that shadowed the
/// surface they lie on left the real forests of models with solids 4-10 % dark, README *A
/// solid's rims in its own light*.)
#[test]
fn a_solids_rims_do_not_shadow_the_surface_they_lie_on() {
    let (radius, cell) = (1.3f64, 0.25f64);
    let eye = Vec3::new(0.0, 0.0, 10.0);
    let sun = Sun {
        direction: Vec3::new(40f32.to_radians().sin(), 0.0, 40f32.to_radians().cos()),
        irradiance: std::f32::consts::PI,
    };
    let light = |texel: Texel| {
        let scene = lone_scene(texel, eye.as_dvec3(), sun);
        // Points on the lit side, each leaving a tenth of a cell off the surface as a
        // solid's shadow ray does (`light_solid`).
        let (mut sum, mut count) = (0.0f32, 0);
        for (k, (i, j)) in (0..9).flat_map(|i| (0..9).map(move |j| (i, j))).enumerate() {
            let n =
                (sun.direction + Vec3::new(i as f32 - 4.0, j as f32 - 4.0, 0.0) * 0.08).normalize();
            let leave = n * (radius + 0.1 * cell) as f32;
            sum += transmittance(
                &scene,
                Ray {
                    origin: leave - eye,
                    dir: sun.direction,
                },
                f32::INFINITY,
                &March::default(),
                &Caster {
                    footprint: 0.0,
                    key: k as u64,
                    own: &[OwnTree {
                        instance: 0,
                        level: 0,
                        factor: 1.0,
                        exact: true,
                    }],
                    draw: &Draw::Texel,
                },
            );
            count += 1;
        }
        sum / count as f32
    };
    let bare = light(solid_ball(radius));
    let rim = light(ball_with_shell(radius, (0.0, 0.5 * cell), f64::MIN, 24.0));
    let shell = light(ball_with_shell(
        radius,
        (2.0 * cell, 3.0 * cell),
        f64::MIN,
        6.0,
    ));
    assert!(
        bare > 0.999,
        "the bare ball shadows its own lit side: {bare}"
    );
    assert!(rim > 0.95, "the rim shadows the surface it lies on: {rim}");
    assert!(shell < 0.5, "a shell off the surface lets through {shell}");
}

/// A solid's surface is shadowed by its own tree's density as the level's leaves are, by
/// the level's self-shadowing: a shell of density beside the ball, which the eye's rays to
/// the ball do not cross and the sun's rays from its lit side do (the sun 100 degrees from
/// the eye), darkens that side at factor 1 and not at factor 0.
#[test]
fn a_solids_own_density_shadows_it_by_the_levels_self_shadowing() {
    let radius = 1.3f64;
    let eye = Vec3::new(0.0, 0.0, 10.0);
    let sun = Sun {
        direction: Vec3::new(100f32.to_radians().sin(), 0.0, 100f32.to_radians().cos()),
        irradiance: std::f32::consts::PI,
    };
    let mean = |factor: f32| {
        let mut texel = ball_with_shell(radius, (0.25, 0.6), 1.45, 6.0);
        for l in &mut texel.levels {
            l.self_shadow = SelfShadow::uniform([factor; 6]);
        }
        let scene = lone_scene(texel, eye.as_dvec3(), sun);
        let (mut sum, mut count) = (0.0f32, 0);
        for (k, (i, j)) in (0..5).flat_map(|i| (0..7).map(move |j| (i, j))).enumerate() {
            let target = Vec3::new(0.6 + i as f32 * 0.08, j as f32 * 0.1 - 0.3, 0.0);
            let r = radiance(
                &scene,
                (target - eye).normalize(),
                0.0,
                k as u64,
                &March::default(),
            );
            assert!(r.transmittance == 0.0, "the ray to {target} went through");
            sum += r.rgb[0];
            count += 1;
        }
        sum / count as f32
    };
    let (free, shadowed) = (mean(0.0), mean(1.0));
    assert!(
        free > 0.0 && shadowed < 0.7 * free,
        "factor 1 {shadowed}, factor 0 {free}"
    );
}

/// A sample's wood is shaded as its own texture says: a texture without wood normals (baked
/// before texel 1.4) keeps its gradient's normal beside one that has them, whose crown the
/// ray crosses at the same point (the choice was once any texture's along the ray).
#[test]
fn wood_is_shaded_by_its_own_textures_normals_not_a_neighbours() {
    let wood = uniform_texel(
        [8, 8, 8],
        0.5,
        DVec3::new(-2.0, 0.0, -2.0),
        1.0,
        [0.3, 0.5, 0.2],
    );
    let mut crown = wood.clone();
    for l in &mut crown.levels {
        l.density.swap(0, 1);
        l.gradient.swap(0, 1);
    }
    let mut flagged = crown.clone();
    for l in &mut flagged.levels {
        l.wood_normals = vec![[0.0, 1.0, 0.0, 0.0, 0.0, 0.0]; l.cell_count()];
    }
    let image = |second: &Texel| {
        let scene = Scene::new(
            DVec3::new(1.0, 5.0, 12.0),
            vec![wood.clone(), second.clone()],
            vec![look(), Look { texel: 1, ..look() }],
            &[
                placed(DVec3::ZERO),
                Placed {
                    look: 1,
                    ..placed(DVec3::new(0.7, 0.3, 0.4))
                },
            ],
            None,
            Lighting {
                sun: Sun::from_angles(220.0, 35.0, std::f32::consts::PI),
                shading: Shading::default(),
                sky: None,
            },
        );
        let camera =
            Camera::look_at(scene.origin, DVec3::new(0.5, 1.5, 0.0), 40.0, 32, 24).unwrap();
        let settings = RenderSettings {
            method: super::Method::Texel,
            spp: 4,
            ..RenderSettings::default()
        };
        super::render(&scene, &camera, &settings, &|_| {}).rgba
    };
    let (plain, beside_normals) = (image(&crown), image(&flagged));
    assert!(plain.iter().flatten().any(|&v| v > 0.0));
    assert!(
        plain == beside_normals,
        "the neighbour's normals shaded this wood"
    );
}
