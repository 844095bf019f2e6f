//! The sun's light at a point: the transmittance towards the sun through every texture and
//! the terrain (equation 2), and the Russian roulette that decides which samples cast a
//! shadow ray at all.

use glam::Vec3;

use super::lod::Draw;
use super::mesh;
use super::scene::Scene;
use super::shading::sun_radiance;
use super::walk::{Active, March, SIGMA_MAX, ShadowRays, floor, level_for};
use crate::geom::Ray;
use crate::rng::{self, purpose};

/// A tree a foliage sample lies in, as its shadow ray must cross it: at the sample's level,
/// its extinction times the level's self-shadowing factor (`Level::self_shadow`, for the
/// angle between eye and sun and the sun's height).
#[derive(Clone, Copy, Default)]
pub struct OwnTree {
    pub instance: u32,
    pub level: usize,
    pub factor: f32,
    /// Marched even where shadows are cached, its first cell left out (solid and density):
    /// the tree of a ray leaving a solid's surface, whose grid of depths would blur the
    /// surface the ray starts on, whose first cell the smoothed normal it left by may graze
    /// again, and whose rims (what the level set left out as density) lie on that surface; and
    /// of any sample of a tree with solids, which lies on a solid's surface where the level
    /// set left a rim out as density.
    pub exact: bool,
}

/// A shadow ray's origin as its march needs it: the footprint (m) the textures are read at,
/// the key of its draws, the trees the sample lies in, and how its sample draws the trees.
#[derive(Clone, Copy)]
pub struct Caster<'a> {
    pub footprint: f32,
    pub key: u64,
    pub own: &'a [OwnTree],
    pub draw: &'a Draw,
}

/// At most this many trees containing one sample get their self-shadowing; further ones (a
/// pile of coincident boxes) are crossed as any other tree.
pub(super) const MAX_OWN: usize = 8;

/// Transmittance along `ray` (from its origin, unit direction) up to `t_max` through every tree
/// and the terrain, as the [`Caster`] sees them: through the textures of the trees its `draw`
/// draws as textures, its `footprint` picking the level, those in its `own` crossed as
/// [`OwnTree`] says; stopped by the polygon models of the others (their alpha-blended
/// triangles drawn from the key's mesh stream, as the mesh method's shadow rays draw them).
///
/// Optical depth is a sum over the instances the ray crosses, and a sum does not care about
/// order: so unlike a view ray, a shadow ray needs no front-to-back walk. It visits the
/// instances in plain traversal order, marches each box on its own, and stops as soon as the
/// depth so far already puts the transmittance below the cut-off.
pub fn transmittance(scene: &Scene, ray: Ray, t_max: f32, march: &March, caster: &Caster) -> f32 {
    let Caster {
        footprint,
        key,
        own,
        draw,
    } = *caster;
    if let Some(g) = &scene.ground
        && g.occluded(&ray, t_max)
    {
        return 0.0;
    }
    let opaque = -march.cutoff.ln();
    // The cached depths run from a point to beyond the tree, towards the sun the scene was
    // built for: any other ray is marched.
    let cached = march.shadows == ShadowRays::Cached
        && t_max == f32::INFINITY
        && scene.sun_beam.carries(&ray);
    let lod_bias = march.lod_bias + march.shadow_lod;
    let mut depth = 0.0f32;
    let mesh_key = rng::mix64(key ^ purpose::MESH_SHADOW);
    let march_key = rng::hash3(key, 0, purpose::SHADOW_MARCH);
    // A tree drawn from its model for this sample stops the light if the ray hits it.
    let model_blocks = |i: u32, local: &Ray| mesh::blocks(scene, i, local, t_max, mesh_key);
    if cached {
        scene.sun_beam.visit_along(&ray, |i| {
            if !draw.texel(scene, i) {
                if model_blocks(i, &scene.instances.get(i).local_ray(&ray)) {
                    depth = f32::INFINITY;
                }
            } else {
                match own.iter().find(|o| o.instance == i) {
                    Some(o) if o.exact => {
                        let local = scene.instances.get(i).local_ray(&ray);
                        if let Some((enter, exit)) =
                            scene.instances.local_interval(i, &local, t_max)
                        {
                            let a = own_active(scene, i, &local, exit, o);
                            depth = marched(
                                scene,
                                &a,
                                (enter, exit),
                                (march, march_key),
                                (depth, opaque),
                                a.step,
                            );
                        }
                    }
                    Some(o) => depth = near_then_cached(scene, &ray, o, (depth, opaque)),
                    None => {
                        let level = level_for(scene, i, footprint, lod_bias);
                        depth += scene.sun_depth.depth(scene, i, level, &ray, 1.0);
                    }
                }
            }
            // Stops the traversal once nothing further can make the light visible.
            depth <= opaque
        });
        return if depth > opaque { 0.0 } else { (-depth).exp() };
    }
    scene
        .sun_beam
        .visit(&scene.instances, &ray, t_max, |i, local, _| {
            if !draw.texel(scene, i) {
                if model_blocks(i, local) {
                    depth = f32::INFINITY;
                    return Some(0.0);
                }
                return None;
            }
            let own = own.iter().find(|o| o.instance == i);
            let (enter, exit) = scene.instances.local_interval(i, local, t_max)?;
            let (a, clear) = match own {
                Some(o) => {
                    let a = own_active(scene, i, local, exit, o);
                    (a, if o.exact { a.step } else { 0.0 })
                }
                None => (Active::new(scene, i, local, exit, footprint, lod_bias), 0.0),
            };
            depth = marched(
                scene,
                &a,
                (enter, exit),
                (march, march_key),
                (depth, opaque),
                clear,
            );
            // Stops the traversal where nothing further can make the light visible.
            (depth > opaque).then_some(0.0)
        });
    if depth > opaque { 0.0 } else { (-depth).exp() }
}

/// Cells of its own tree a cached shadow ray marches before it reads the tree's grid.
///
/// What the eye sees of a tree is what its own leaves leave open towards the eye, and with
/// the sun near the eye the same gaps let the sun in: a sample's depth towards the sun is
/// less than that of the points around it, over a few cells along its shadow ray. The grid's
/// lookup mixes four columns a cell apart, and so reads a seen leaf's depth as deep as its
/// neighbours'. Measured at the samples a view draws (CommonTree_1, level 0, the demo's eye,
/// the sun 20 degrees from it; against a fine march): the grid read the mean depth 18 % deep
/// and the transmittance (factor 0.5) 9 % dark; marching the first 1 / 2 / 3 cells, 6 / 2 /
/// 0.5 % dark; the fixture conifer 2.2 % dark, 0.1 % marching 3 (README, *The own tree's
/// shadow near the leaf, marched*). Beyond, the correlation with what the eye sees is gone,
/// and the grid's lookup lets through the light a ray there sees on average (`Grid::at` in
/// `sun_depth`).
const NEAR_CELLS: f32 = 3.0;

/// `depth` plus the optical depth of the tree `o` the ray's sample lies in, cached: its first
/// [`NEAR_CELLS`] cells marched at `o`'s level and factor, the rest read from its grid.
fn near_then_cached(scene: &Scene, ray: &Ray, o: &OwnTree, (depth, opaque): (f32, f32)) -> f32 {
    let i = o.instance;
    let local = scene.instances.get(i).local_ray(ray);
    let Some((enter, exit)) = scene.instances.local_interval(i, &local, f32::INFINITY) else {
        return depth;
    };
    let a = own_active(scene, i, &local, exit, o);
    let near = (enter + NEAR_CELLS * a.step).min(exit);
    let depth = depth + midpoints(scene, &a, (enter, near));
    if near >= exit || depth > opaque {
        return depth;
    }
    let beyond = Ray {
        origin: ray.origin + ray.dir * near,
        dir: ray.dir,
    };
    depth + scene.sun_depth.depth(scene, i, o.level, &beyond, o.factor)
}

/// The optical depth of the tree `a` between `enter` and `exit` along the ray by the midpoint
/// rule, a sample a cell. The near stretch is so marched rather than jittered, as the
/// self-shadowing fit marches it (`bake::seen`): it starts at a random sample already, and
/// jittered its noise raised the fixture forest's far view's error at 1 spp by 0.9 % over no
/// march at all, where the midpoints raise it by 0.5 % (two samples a cell, 0.3 %).
fn midpoints(scene: &Scene, a: &Active, (enter, exit): (f32, f32)) -> f32 {
    let look = &scene.looks[scene.instances.get(a.instance).look as usize];
    let level = &scene.texels[look.texel].levels[a.level];
    let stencils = &scene.occupancy[look.texel][a.level].stencils;
    let samples = ((exit - enter) / a.step).ceil().max(1.0);
    let h = (exit - enter) / samples;
    (0..samples as usize)
        .map(|s| {
            let d = stencils.density_at(level, a.c0 + a.dc * (enter + (s as f32 + 0.5) * h));
            a.extinction(d[0] + look.foliage * d[1]) * h
        })
        .sum()
}

/// A tree the shadow ray's sample lies in, at its level, its extinction times its
/// self-shadowing factor.
fn own_active(scene: &Scene, i: u32, local: &Ray, exit: f32, o: &OwnTree) -> Active {
    let a = Active::at_level(scene, i, local, exit, o.level);
    Active {
        sigma_scale: (a.sigma_scale * o.factor).min(SIGMA_MAX),
        ..a
    }
}

/// `depth` plus the optical depth of the tree `a` between `enter` and `exit` along the ray,
/// by a jittered march (the draws of `march_key`); stops adding once past `opaque`, and is
/// infinite where a sample lies inside a solid. A tree with solids is read only from `clear`
/// along the ray on (both its solid and its density).
fn marched(
    scene: &Scene,
    a: &Active,
    (enter, exit): (f32, f32),
    (march, march_key): (&March, u64),
    (mut depth, opaque): (f32, f32),
    clear: f32,
) -> f32 {
    let i = a.instance;
    let look = &scene.looks[scene.instances.get(i).look as usize];
    let level = &scene.texels[look.texel].levels[a.level];
    let occupancy = &scene.occupancy[look.texel][a.level];
    let foliage = look.foliage;
    let solid = level.has_solid();
    let length = a.step * march.step;
    let mut t = enter;
    let mut segment = 0u64;
    // Up to where the march need not look at the bricks again (empty ones are jumped
    // over; segments run on across occupied ones as they would without bricks).
    let mut looked = t;
    while t < exit {
        if t >= looked {
            let (occupied, until) = occupancy.span(a.c0, a.dc, t, exit);
            // Whole segments that lie in empty bricks are jumped over, with their draws:
            // the segments and samples left are exactly those of a march that skips
            // nothing, so the estimate is unchanged, only cheaper.
            let empty = floor((until - t) / length);
            if !occupied && empty >= 1.0 {
                t += empty * length;
                segment += empty as u64;
                continue;
            }
            // At t's precision no progress: march the rest of the box plainly.
            looked = if until > t { until } else { exit };
        }
        // A step below t's precision would never advance: take the rest in one.
        let end = if t + length > t {
            (t + length).min(exit)
        } else {
            exit
        };
        let ts = t + rng::unit(rng::hash3(march_key, u64::from(i), segment)) as f32 * (end - t);
        // Within `clear` the ray is still in the layer of surfaces its sample stands for: the
        // solid's surface and what of it the level set left out as density (a rim thinner
        // than a cell, lying on that surface), neither of which shadows itself.
        if !(solid && ts < clear) {
            let c = a.c0 + a.dc * ts;
            if solid && level.in_solid(c, foliage) {
                return f32::INFINITY;
            }
            let d = occupancy.stencils.density_at(level, c);
            depth += a.extinction(d[0] + foliage * d[1]) * (end - t);
            if depth > opaque {
                return depth;
            }
        }
        segment += 1;
        t = end;
    }
    depth
}

/// Which of one ray's samples with a small share cast their shadow ray: the roulette of
/// [`roulette`], stratified along the ray. The small shares are laid end to end, in units of
/// `--shadow-share`, from one uniform offset per ray; a sample casts where its stretch
/// crosses a whole number. Each still casts with probability share / shadow-share, whatever
/// came before it (the offset is uniform, so is where its stretch starts between two whole
/// numbers), but a ray casts as many shadow rays as its small shares add up to, give or take
/// one, not a number left to chance: independent draws would leave one ray unlit and light
/// another twice.
pub(super) struct Strata {
    /// The offset plus the small shares so far, in units of the shadow share, less the whole
    /// numbers crossed: in [0, 1), where adding a share rounds it to within 2^-24.
    phase: f32,
}

impl Strata {
    /// A ray's strata, its offset drawn from `key`.
    pub(super) fn new(key: u64) -> Strata {
        Strata {
            // A draw just below 1 rounds to 1 in f32: the same phase as 0.
            phase: (rng::unit(key) as f32).fract(),
        }
    }
}

/// The light `light()` finds, for a sample with `share` of its ray: always computed for a
/// large share, else with probability share / `march.shadow_share` (the ray's `strata`
/// decide) and divided by it, so that its expectation is unchanged and a skipped shadow ray
/// costs nothing. `cast` counts the shadow rays.
pub(super) fn roulette(
    share: f32,
    march: &March,
    strata: &mut Strata,
    cast: &mut u32,
    light: impl FnOnce() -> f32,
) -> f32 {
    if share >= march.shadow_share {
        *cast += 1;
        return light();
    }
    // Any probability works if it is the one divided by; a floor keeps 1/p finite.
    let p = (share / march.shadow_share).max(1e-6);
    // A whole number crossed (p < 1: at most one).
    strata.phase += p;
    if strata.phase >= 1.0 {
        strata.phase -= 1.0;
        *cast += 1;
        light() / p
    } else {
        0.0
    }
}

/// I(t): the sun's radiance scale times the transmittance towards it.
pub(super) fn sun_light(scene: &Scene, p: Vec3, march: &March, caster: &Caster) -> f32 {
    let ray = Ray {
        origin: p,
        dir: scene.sun.direction,
    };
    let t = transmittance(scene, ray, f32::INFINITY, march, caster);
    sun_radiance(scene) * t
}

#[cfg(test)]
mod tests {
    use super::{Strata, roulette};
    use crate::render::March;

    /// Along a ray of small and large shares, the stratified roulette casts each small
    /// sample's shadow ray with probability share / shadow-share, weighted by its inverse
    /// (each sample's light kept in expectation, over the ray's offset), and casts as many
    /// of them as the small shares add up to in units of the shadow share, rounded down or
    /// up: never none on a ray whose small shares add up to a whole shadow share.
    #[test]
    fn stratified_roulette_keeps_each_samples_light_and_spreads_the_rays() {
        let march = March {
            shadow_share: 0.05,
            ..March::default()
        };
        let shares = [
            0.3, 0.2, 0.04, 0.012, 0.031, 0.0007, 0.049, 0.02, 0.0301, 0.005, 0.017, 0.06, 0.01,
        ];
        let small: f64 = shares
            .iter()
            .filter(|&&s| s < march.shadow_share)
            .map(|&s| f64::from(s / march.shadow_share))
            .sum();
        let offsets = 20_000;
        let mut light = vec![0.0f64; shares.len()];
        for k in 0..offsets {
            let mut strata = Strata {
                phase: (k as f32 + 0.5) / offsets as f32,
            };
            let mut cast = 0u32;
            for (l, &share) in light.iter_mut().zip(&shares) {
                *l += f64::from(roulette(share, &march, &mut strata, &mut cast, || 1.0));
            }
            let large = shares.iter().filter(|&&s| s >= march.shadow_share).count() as f64;
            let rouletted = f64::from(cast) - large;
            assert!(
                rouletted == small.floor() || rouletted == small.ceil(),
                "offset {k}: {rouletted} shadow rays for small shares adding up to {small}"
            );
        }
        for (l, share) in light.iter().zip(shares) {
            let mean = l / f64::from(offsets);
            // The offsets are a grid: a sample casting for a fraction p of them is off by at
            // most one offset in p x offsets.
            let p = f64::from(share / march.shadow_share).min(1.0);
            let within = 1.5 / (p * f64::from(offsets));
            assert!((mean - 1.0).abs() < within, "share {share}: light {mean}");
        }
    }
}
