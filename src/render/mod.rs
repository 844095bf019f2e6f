//! `render`: a forest of overlapping 3D textures over a polygon terrain, ray traced with
//! volume rendering (the paper's section 3), to a linear EXR.
//!
//! `camera` makes primary rays, `scene` holds what they meet, `integrate` follows one ray,
//! `film` keeps and writes the pixels. Pixels are computed in tiles in parallel; every random
//! draw is keyed by the pixel and the sample, so the image is the same for any number of
//! threads and a cropped render equals that region of the full one, bit for bit.

pub mod camera;
pub mod camera_path;
pub mod crowding;
pub mod edges;
pub mod film;
pub mod instances;
pub mod integrate;
pub mod leaves;
pub mod load;
pub mod lod;
pub mod matte;
pub mod mesh;
pub mod scene;
pub mod shading;
pub mod sun_depth;
pub mod sunlight;
pub mod view;
pub mod walk;

use rayon::prelude::*;

pub use camera::Camera;
pub use edges::Edges;
pub use film::{Aovs, Film};
use lod::Draw;
pub use lod::Lod;
pub use matte::MatteNames;
pub use scene::{Ground, Lighting, Look, Placed, Scene, Shading, Sun};
pub use shading::Radiance;
pub use walk::{March, ShadowRays};

#[cfg(test)]
mod hybrid_tests;
#[cfg(test)]
mod matte_tests;
#[cfg(test)]
pub(crate) mod mesh_tests;
#[cfg(test)]
mod tests;

use crate::rng;

const TILE: u32 = 32;

/// How trees are drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Method {
    /// Volume rendering of the 3D textures (the paper's method).
    #[default]
    Texel,
    /// Ray tracing the polygon models the textures were baked from (the conventional method;
    /// at many samples per pixel, the ground truth). Needs [`Scene::with_meshes`].
    Mesh,
    /// Each tree from whichever of the two its footprint needs (`lod`). Needs
    /// [`Scene::with_meshes`].
    Hybrid,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    pub method: Method,
    /// Samples per pixel, one in each of `spp` strata of equal area ([`Strata`]).
    pub spp: u32,
    /// Each sample's ray through a random point of its stratum, not its centre. Jittered, the
    /// pixel's estimate is unbiased: renders with different seeds average to the pixel's mean,
    /// as a reference must. Centred (the default) has no noise from where in its pixel a ray
    /// goes, and measured nearer the references for every method at 1, 4 and 16 spp (README,
    /// *Measured*): the midpoint rule, whose error on a pixel the footprint's texture level
    /// has already smoothed is second order in the stratum's size (pbrt's stratified sampler
    /// without jitter does the same).
    pub jitter: bool,
    pub march: March,
    /// Where the hybrid method switches from meshes to textures.
    pub lod: Lod,
    /// x0, y0, x1, y1 (exclusive) of the part of the frame to render.
    pub crop: Option<[u32; 4]>,
    pub seed: u64,
    /// Keys the hybrid method's draw of each tree in the transition band: one draw per tree
    /// for the whole frame, and for every frame of a sequence that shares it, so that a tree
    /// changes representation once as the camera comes nearer rather than from frame to
    /// frame. Over seeds, a tree is a texture with the band's probability.
    pub lod_seed: u64,
    /// Pixels at edges sampled again with more samples (`edges`); `None` samples every pixel
    /// alike.
    pub edges: Option<Edges>,
    /// Record each pixel's coverage by tree, species, terrain and sky (`matte`).
    pub mattes: bool,
    /// The layers the film keeps besides RGBA and Z: those its file will carry (default
    /// all).
    pub layers: Aovs,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            method: Method::Texel,
            spp: 1,
            jitter: false,
            march: March::default(),
            lod: Lod::default(),
            crop: None,
            seed: 0,
            lod_seed: 0,
            edges: None,
            mattes: false,
            layers: Aovs::ALL,
        }
    }
}

/// Whether rendering with `settings` through `camera` draws any tree of `scene` from its
/// polygon model, and so needs [`Scene::with_meshes`]: the mesh method always; the hybrid
/// method where the footprint of its samples (or of its edges' samples) is fine enough for a
/// tree within the frame's reach to be a model ([`lod::Draw::simplified`]); the texel method
/// never. A hybrid frame of a far forest then reads no model at all.
pub fn draws_models(scene: &Scene, camera: &Camera, settings: &RenderSettings) -> bool {
    std::iter::once(settings.spp)
        .chain(settings.edges.map(|e| e.spp))
        .any(|spp| {
            !matches!(
                Sampling::new(camera, spp, scene, settings).draw,
                Draw::Texel
            )
        })
}

/// Renders `scene` through `camera`; `progress` is told each finished tile's pixel count.
pub fn render(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> Film {
    let [x0, y0, x1, y1] = settings.crop.unwrap_or([0, 0, camera.width, camera.height]);
    let mut film = Film::keeping(
        x0,
        y0,
        x1 - x0,
        y1 - y0,
        (camera.width, camera.height),
        settings.layers,
    );
    if settings.mattes {
        film.mattes = vec![Mattes::EMPTY; film.rgba.len()];
    }
    let tiles: Vec<(u32, u32)> = (y0..y1)
        .step_by(TILE as usize)
        .flat_map(|ty| (x0..x1).step_by(TILE as usize).map(move |tx| (tx, ty)))
        .collect();
    // A caller's mistake, not an input's: `texel render` gives a frame its models wherever
    // this holds, or draws it from textures and says why.
    assert!(
        scene.meshes.len() == scene.texels.len() || !draws_models(scene, camera, settings),
        "this frame draws trees from their models: the scene needs them (Scene::with_meshes)"
    );
    let base = Sampling::new(camera, settings.spp, scene, settings);
    scene.choose(&base.draw);
    // Each tile's pixels go into the film as soon as the tile is done, under a lock held for
    // the copy alone: the film is the run's one image-sized allocation (pixels gathered
    // frame-wide before the copy were another as large, 160 MB at 1920 x 1080, and the copy
    // was serial). Each pixel is written once, so the order tiles finish in changes nothing.
    let rows = |ty: u32| ty..(ty + TILE).min(y1);
    let columns = |tx: u32| tx..(tx + TILE).min(x1);
    let shared = std::sync::Mutex::new(film);
    tiles.par_iter().for_each_init(
        || Vec::with_capacity((TILE * TILE) as usize),
        |out, &(tx, ty)| {
            out.clear();
            for y in rows(ty) {
                for x in columns(tx) {
                    out.push(pixel(scene, camera, settings, x, y, &base));
                }
            }
            progress(out.len() as u64);
            let places = rows(ty).flat_map(|y| columns(tx).map(move |x| (x, y)));
            // A panic elsewhere poisons the lock; the run is failing anyway.
            let mut film = shared.lock().unwrap_or_else(|e| e.into_inner());
            let width = film.width;
            for ((x, y), p) in places.zip(out.drain(..)) {
                film.put((x - x0 + width * (y - y0)) as usize, p);
            }
        },
    );
    let mut film = shared.into_inner().unwrap_or_else(|e| e.into_inner());
    if let Some(edges) = settings.edges {
        sample_edges(scene, camera, settings, &edges, &base, &mut film);
    }
    film
}

/// How the samples of a pixel are laid: their count, their strata, each one's footprint per
/// metre of distance, and how they draw the trees.
struct Sampling {
    spp: u32,
    strata: Strata,
    spread: f32,
    draw: Draw,
}

impl Sampling {
    /// A pass of `spp` samples a pixel, drawing `scene`'s trees as `settings.method` does:
    /// the hybrid's choice at this footprint and count (`Lod::for_samples`), as cheaply as
    /// it allows (`Draw::simplified`: every tree a texture, or every tree a model, where
    /// that is what the choice comes to).
    fn new(camera: &Camera, spp: u32, scene: &Scene, settings: &RenderSettings) -> Sampling {
        // Each sample stands for its stratum of the pixel, not the whole pixel: its
        // footprint, which picks the mip level, is the stratum's (the side of a square of its
        // area). More samples then read finer levels, and the image converges to the finest
        // level's, not to the pixel-sized level's bias.
        let spread = camera.pixel_angle() as f32 / (spp as f32).sqrt();
        let draw = match settings.method {
            Method::Texel => Draw::Texel,
            Method::Mesh => Draw::Mesh,
            Method::Hybrid => {
                let lod = settings.lod.for_samples(spp);
                Draw::hybrid(lod, spread, lod_key(settings)).simplified(scene)
            }
        };
        Sampling {
            spp,
            strata: Strata::new(spp),
            spread,
            draw,
        }
    }
}

/// Renders again, at `edges.spp`, the pixels of `film` (the first pass, at `base`) that
/// differ from a neighbour ([`Edges::find`]). A crop's pixels at its border are compared with
/// the first pass of the pixels just outside it, rendered here; their work is not the film's,
/// so a crop's work stays its region's. The second pass is not reported to `progress`, whose
/// count is the frame's pixels.
fn sample_edges(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    edges: &Edges,
    base: &Sampling,
    film: &mut Film,
) {
    let region = [
        film.x0,
        film.y0,
        film.x0 + film.width,
        film.y0 + film.height,
    ];
    let frame = (camera.width, camera.height);
    let ring: std::collections::HashMap<(u32, u32), [f32; 4]> = edges::ring(region, frame)
        .into_par_iter()
        .map(|(x, y)| ((x, y), pixel(scene, camera, settings, x, y, base).rgba))
        .collect();
    let at_edges = edges.find(region, frame, |x, y| {
        if (region[0]..region[2]).contains(&x) && (region[1]..region[3]).contains(&y) {
            film.rgba[(x - region[0] + film.width * (y - region[1])) as usize]
        } else {
            // Every neighbour outside the region that `find` asks for is in the ring.
            ring.get(&(x, y)).copied().unwrap_or([0.0; 4])
        }
    });
    let mut places = Vec::with_capacity(at_edges.iter().filter(|&&m| m).count());
    places.extend((0..at_edges.len() as u32).filter(|&i| at_edges[i as usize]));
    drop(at_edges);
    let more = Sampling::new(camera, edges.spp, scene, settings);
    let shared = std::sync::Mutex::new(film);
    places.par_chunks(64).for_each(|chunk| {
        let width = region[2] - region[0];
        let pixels: Vec<(usize, Pixel)> = chunk
            .iter()
            .map(|&i| {
                let (x, y) = (region[0] + i % width, region[1] + i / width);
                (i as usize, pixel(scene, camera, settings, x, y, &more))
            })
            .collect();
        let mut film = shared.lock().unwrap_or_else(|e| e.into_inner());
        for (i, p) in pixels {
            film.put_again(i, p);
        }
    });
}

impl Film {
    /// Keeps pixel `p` as film pixel `i`, in the layers the film keeps.
    fn put(&mut self, i: usize, p: Pixel) {
        fn keep<T>(layer: &mut [T], i: usize, value: T) {
            if let Some(v) = layer.get_mut(i) {
                *v = value;
            }
        }
        self.rgba[i] = p.rgba;
        self.z[i] = p.z;
        keep(&mut self.normal, i, p.normal);
        keep(&mut self.albedo, i, p.albedo);
        keep(&mut self.canopy, i, p.canopy);
        keep(&mut self.mesh_canopy, i, p.mesh_canopy);
        keep(&mut self.band_canopy, i, p.band_canopy);
        keep(&mut self.species, i, p.species);
        keep(&mut self.samples, i, p.samples);
        keep(&mut self.shadow_rays, i, p.shadow_rays);
        self.add_work(p.samples, p.shadow_rays);
        if let Some(m) = p.mattes {
            self.mattes[i] = *m;
        }
    }

    /// Replaces pixel `i` with `p`, rendered again with more samples: the first pass's work
    /// still counts, in the pixel's and in the frame's.
    fn put_again(&mut self, i: usize, p: Pixel) {
        let samples = self.samples.get(i).copied();
        let shadow_rays = self.shadow_rays.get(i).copied();
        self.put(i, p);
        if let (Some(s), Some(before)) = (self.samples.get_mut(i), samples) {
            *s += before;
        }
        if let (Some(s), Some(before)) = (self.shadow_rays.get_mut(i), shadow_rays) {
            *s += before;
        }
        self.sampled_again += 1;
    }
}

/// What the film keeps of a pixel.
struct Pixel {
    rgba: [f32; 4],
    z: f32,
    /// The AOVs of the pixel's first sample (normal, albedo and species do not average).
    normal: glam::Vec3,
    albedo: glam::Vec3,
    species: f32,
    /// The trees' opacity, the mean over the samples: a matte of the canopy.
    canopy: f32,
    /// The part of `canopy` drawn from polygon models, the mean over the samples.
    mesh_canopy: f32,
    /// The part of `canopy` drawn from trees in the transition band, the mean over the samples.
    band_canopy: f32,
    /// Work for the whole pixel, all its samples.
    samples: f32,
    shadow_rays: f32,
    /// With mattes: the pixel's coverage by tree and by species.
    mattes: Option<Box<Mattes>>,
}

/// Keys the hybrid method's draw of each tree in the band (`RenderSettings::lod_seed`).
fn lod_key(settings: &RenderSettings) -> u64 {
    rng::hash3(settings.lod_seed, 0, rng::purpose::LOD)
}

/// `spp` strata of equal area tiling a pixel: `rows` rows of `columns` each, as nearly square
/// as `spp` allows (the rows are its largest divisor not above its square root: 4 is 2 x 2,
/// 2 is 1 x 2, 6 is 2 x 3, a prime is a row of upright strips). Equal areas keep the mean of the
/// samples the pixel's mean for any `spp`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Strata {
    pub columns: u32,
    pub rows: u32,
}

impl Strata {
    pub fn new(spp: u32) -> Strata {
        let spp = spp.max(1);
        let rows = (1..=spp.isqrt())
            .rev()
            .find(|&r| spp.is_multiple_of(r))
            .unwrap_or(1);
        Strata {
            columns: spp / rows,
            rows,
        }
    }

    /// Where sample `s` goes in its pixel, in the unit square: its stratum's centre, or with
    /// `jitter` a point drawn uniformly within the stratum by `key`.
    pub fn place(&self, s: u32, jitter: Option<u64>) -> (f64, f64) {
        let (i, j) = (
            (s % self.columns) as f64,
            ((s / self.columns) % self.rows) as f64,
        );
        let (u, v) = jitter.map_or((0.5, 0.5), |key| {
            (rng::unit(key), rng::unit(rng::mix64(key)))
        });
        ((i + u) / self.columns as f64, (j + v) / self.rows as f64)
    }
}

/// The mean of a pixel's samples, one in each of its strata.
fn pixel(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    x: u32,
    y: u32,
    sampling: &Sampling,
) -> Pixel {
    let Sampling {
        spp,
        ref strata,
        spread,
        draw,
    } = *sampling;
    let pixel_key = rng::hash3(
        settings.seed,
        ((y as u64) << 32) | x as u64,
        rng::purpose::PIXEL,
    );
    let (mut rgba, mut first, mut z) = ([0.0f32; 4], None, f32::INFINITY);
    let (mut samples, mut shadow_rays) = (0u64, 0u64);
    let (mut canopy, mut mesh_canopy, mut band_canopy) = (0.0f32, 0.0f32, 0.0f32);
    let mut coverage = matte::Coverage::default();
    for s in 0..spp {
        matte::begin(settings.mattes);
        let key = rng::hash3(pixel_key, s as u64, 0);
        let (u, v) = strata.place(s, settings.jitter.then_some(key));
        let dir = camera.direction(x as f64 + u, y as f64 + v);
        let ray_key = rng::mix64(key ^ rng::purpose::RAY);
        let r = match draw {
            // Every tree a model, in the hybrid method too: the same light, less work.
            Draw::Mesh => mesh::radiance(scene, dir, ray_key),
            Draw::Texel | Draw::Hybrid { .. } => {
                integrate::hybrid(scene, dir, spread, ray_key, &settings.march, draw)
            }
        };
        for c in 0..3 {
            rgba[c] += r.rgb[c];
        }
        rgba[3] += 1.0 - r.transmittance;
        if settings.mattes {
            coverage.end_sample(1.0 - r.transmittance);
        }
        canopy += r.canopy;
        mesh_canopy += r.mesh_canopy;
        band_canopy += r.band_canopy;
        samples += u64::from(r.samples);
        shadow_rays += u64::from(r.shadow_rays);
        if r.distance.is_finite() {
            z = z.min(camera.depth(dir * r.distance));
        }
        first.get_or_insert(r);
    }
    let mattes = settings.mattes.then(|| {
        Box::new(Mattes {
            trees: coverage.ranks(spp, |o| o),
            species: coverage.ranks(spp, |o| species_of(scene, o)),
        })
    });
    let n = spp as f32;
    // A non-finite value would poison every composite downstream; none should arise, but an
    // image must never carry one.
    let rgba = rgba.map(|v| if v.is_finite() { v / n } else { 0.0 });
    let rgba = [rgba[0], rgba[1], rgba[2], rgba[3].clamp(0.0, 1.0)];
    let first = first.unwrap_or_default();
    Pixel {
        rgba,
        z,
        normal: first.normal,
        albedo: first.albedo,
        species: first.species,
        canopy: (canopy / n).clamp(0.0, 1.0),
        mesh_canopy: (mesh_canopy / n).clamp(0.0, 1.0),
        band_canopy: (band_canopy / n).clamp(0.0, 1.0),
        samples: samples as f32,
        shadow_rays: shadow_rays as f32,
        mattes,
    }
}

/// A pixel's most-covering trees and species (`matte`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mattes {
    pub trees: matte::Ranks,
    /// Species by index; the terrain and the sky keep their codes.
    pub species: matte::Ranks,
}

impl Mattes {
    pub const EMPTY: Mattes = Mattes {
        trees: [(0, 0.0); matte::RANKS],
        species: [(0, 0.0); matte::RANKS],
    };
}

/// The species of object `o` (a tree), or the object itself (the terrain, the sky).
fn species_of(scene: &Scene, o: u32) -> u32 {
    if o == matte::TERRAIN || o == matte::SKY {
        o
    } else {
        u32::from(scene.instances.get(o).look)
    }
}

/// The memory a render is checked for before it starts covers what it holds per pixel: the
/// layers its film keeps and the EXR's channels twice, as samples and as the encoded file,
/// for every choice of layers. (The tiles' pixels are a tile's per thread, not the frame's.)
#[test]
fn the_memory_bound_per_pixel_covers_what_a_render_holds() {
    use std::mem::size_of;
    let f32s = size_of::<f32>();
    for bits in 0..128u32 {
        let bit = |k: u32| bits >> k & 1 == 1;
        let aovs = Aovs {
            normal: bit(0),
            albedo: bit(1),
            canopy: bit(2),
            species: bit(3),
            lod: bit(4),
            samples: bit(5),
            cryptomatte: bit(6),
        };
        // What a one-pixel film keeps (a render adds the ranks where it records mattes).
        let film = Film::keeping(0, 0, 1, 1, (1, 1), aovs);
        let mut held = size_of::<[f32; 4]>()
            + film.z.len() * f32s
            + (film.normal.len() + film.albedo.len()) * size_of::<glam::Vec3>()
            + (film.canopy.len() + film.mesh_canopy.len() + film.band_canopy.len()) * f32s
            + (film.species.len() + film.samples.len() + film.shadow_rays.len()) * f32s;
        if aovs.cryptomatte {
            held += size_of::<Mattes>();
        }
        // R G B A Z, normal, albedo, canopy, lod, species, samples, Cryptomatte.
        let channels = 5
            + 3 * usize::from(aovs.normal)
            + 3 * usize::from(aovs.albedo)
            + usize::from(aovs.canopy)
            + 3 * usize::from(aovs.lod)
            + usize::from(aovs.species)
            + 2 * usize::from(aovs.samples)
            + 32 * usize::from(aovs.cryptomatte);
        held += 2 * channels * f32s;
        assert!(aovs.bytes_per_pixel() >= held as u64, "{aovs:?}: {held}");
    }
    assert_eq!(Aovs::default().bytes_per_pixel(), 60);
}
