//! What the eye sees of each mip level, made to be what it sees of the mesh: the wood's share
//! of the surfaces seen, and how much the foliage shadows the leaves seen.
//!
//! **Wood share.** A coarse cell mixes a trunk with the needles around it; scattering in
//! proportion to extinction, it shows the wood as much as the foliage, where the mesh hides
//! the trunk inside the crown (the fixture conifer's coarse levels came out 21 % redder).
//! Since texel 1.7 each cell stores the wood's density as it counts in choosing which part
//! scatters ([`wood_shown`]), so that the cell shows its wood first as often as the mesh does
//! within it. Each level also keeps, for older readers, one weight `w` on the wood's
//! extinction, fitted so that the wood's share of what 12 views of the lone tree see equals
//! the share of the mesh's first hits that are wood. That weight was ill-posed: it moved the
//! wood of the crown's leafy cells, where it acts least in those views, to make up for a trunk
//! under the crown it cannot move, and reached its bounds on four of the shared real trees
//! (README, *The wood a crown hides, cell by cell*).
//!
//! **Self-shadowing.**
//! A volume shadows itself wrongly in two ways, both measured on the fixture forest:
//!
//! - **Clumping.** A visible leaf sits in a clump, so the first stretch of its shadow ray
//!   crosses more foliage than the cell's mean; a coarse level averages the clumps away and
//!   puts its samples in the blurred fringe of the crown, whose path to the sun is short. Coarse
//!   levels were up to 15 % too bright under a sun behind the camera.
//! - **The hot spot.** Where the sun is behind the eye, the eye's ray and the sun's ray from a
//!   visible leaf run side by side through the same gaps: what the eye sees is lit (the
//!   opposition effect of vegetation canopies; Kuusk 1985). Independent media miss that
//!   correlation, so a volume is too dark near the hot spot.
//!
//! Both depend on the angle `g` between the directions to the eye and to the sun, on the
//! level, and on where the sun and the eye stand, measured (the fixture conifer, level 0, 90
//! degrees from the eye, needs 3.1 with the sun on the horizon and 7.9 with it overhead; seen
//! from 25 degrees up with the sun 20 degrees from the eye, 1.12 with the sun above the eye's
//! line of sight, 0.56 beside it and 0.78 below it). So each level stores a factor per angle in
//! [`SELF_SHADOW_ANGLES`] and, since texel 1.6, per eye height in [`EYE_HEIGHTS`] and turn of
//! the sun about the eye's line of sight in [`SUN_TURNS`]; beside them the rows older readers
//! use, per sun height in [`SUN_HEIGHTS`] (1.5) and one pooled over every sun (1.2): the
//! multiplier on the tree's own extinction along a foliage sample's shadow ray that makes the
//! mean sun visibility of what the eye sees equal the mesh's. Keyed by the sun's height alone,
//! the lone fixture trees' leaves under a sun 20 degrees above the eye's line of sight were
//! 15-19 % too sunlit: a height's row pools the suns of every view that stand at that height,
//! above one eye's line of sight and beside or below another's.
//!
//! The measurement. For 12 view directions `v` (elevations 10, 35 and 60 degrees, 4 azimuths)
//! and each angle, [`SUNS_PER_ANGLE`] sun directions `l` at that angle from `v`, turned about
//! it, those above the horizon kept. On the mesh, parallel rays travelling along `-v`, 16 per
//! level-0 cell over the box's shadow ([`MESH_RAY_SPACING`]): each ray's first surface, where
//! it is foliage, counts with the weight of its Lambert response `max(0, n . l)` (`n` facing
//! the eye) and the verdict of a shadow ray towards `l` (alpha-tested, as the mesh method
//! shades). On the level, a lattice of such rays one per level-0 cell, each marched (midpoint
//! rule, half a cell) and its foliage samples weighted as the renderer weights them
//! (`T (1 - exp(-sigma dt))` times the foliage's share of sigma, each part turned along the
//! view as the renderer's view rays turn it, `volume::PartFacing`); a point drawn from those
//! weights carries the optical depth towards `l`, weighted by its leaves' response to `l` as
//! the renderer shades them ([`Drawn`]). Each sun counts in the pooled row with weight 1, in
//! the rows by sun height with the weights by which the renderer interpolates between them,
//! and in the row by eye height and sun turn whose node it stands at ([`row_weights`]). The
//! factor `k` solves `sum w W R exp(-k tau) / sum w W R = mesh visibility` (within
//! `[0, K_MAX]`).
//!
//! Measured against the renderers (stop 54; the texel method's sunlit share over the mesh
//! method's for lone trees seen from 10 and 25 degrees up, suns at and between the nodes, 96
//! cases over three trees): the fit's mesh side at one ray a cell met about 200 leaves a view
//! and read a leaf-card tree's low-eye row 12 % dark; its texture side, unweighted by the
//! leaves' response, read the renderer's texture 6-10 % bright; and each node pooled its
//! neighbours' suns. The three together took the cases' RMS distance from 1 from 8.6 % to
//! 6.5 %, the leaf-card tree's low-eye node from 0.83 to 0.96 (README, *Where the
//! self-shadowing fit departed from the renderer, found*).

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::calibrate::{bisect_log, midpoints, newton_bracketed};
use crate::geom::{Ray, barycentric_point, offset_origin};
use crate::import::Mesh;
use crate::mesh_tracer::MeshTracer;
use crate::render::leaves::{EVEN, VisibleNormals};
use crate::rng;
use crate::volume::{
    EYE_HEIGHTS, ISOTROPIC_LEAVES, Level, PartFacing, SELF_SHADOW_ANGLES, SOLID_EXTINCTION,
    SUN_HEIGHTS, SUN_TURNS, SelfShadow, Sparse, SunFromEye, hat,
};

/// Parallel rays along `-v` over the box's shadow, keyed by a stream, each as (origin before
/// the box, parameter after it): [`super::calibrate::lattice`] at some spacing.
type Lattice<'a> = &'a dyn Fn(DVec3, u64) -> Vec<(DVec3, f64)>;

/// The largest factor a fit may give.
const K_MAX: f64 = 16.0;
/// Spacing of the view rays, in level-0 cells (1.5 left the broadleaf's coarse levels 2 % brighter
/// near the hot spot: the fit's own noise).
const RAY_SPACING: f64 = 1.0;
/// Spacing of the view rays that find the mesh's leaves, in level-0 cells: sixteen to a view
/// ray of the level's. A small tree's views meet a few hundred leaves at one a cell, and a
/// row's mean visibility from so few strayed by up to 15 % (CommonTree_1 seen from 10 degrees
/// up, sun 60 degrees from the eye beside it: 0.315 against the mesh method's 0.36). They make
/// the bake 1.12-1.22x slower (stop 54).
const MESH_RAY_SPACING: f64 = 0.25;
/// Points drawn per view ray from its foliage samples (two, with four suns per angle, took
/// 1.3x the bake's time and moved no lone tree's sunlit share by more than 0.03).
const POINTS_PER_RAY: usize = 1;

/// The view directions: elevations 10, 35 and 60 degrees at 4 azimuths (45 degrees apart
/// from the axes, so no view looks straight along the grid).
fn views() -> Vec<DVec3> {
    let mut v = Vec::new();
    for elevation in [10f64, 35.0, 60.0] {
        for k in 0..4 {
            let azimuth = (45.0 + 90.0 * k as f64 + 20.0 * elevation / 35.0).to_radians();
            let (e, a) = (elevation.to_radians(), azimuth);
            v.push(DVec3::new(e.cos() * a.cos(), e.sin(), e.cos() * a.sin()));
        }
    }
    v
}

/// `v` turned up towards +Y by `degrees`, about the horizontal axis perpendicular to it.
fn turned_up(v: DVec3, degrees: f64) -> DVec3 {
    let horizontal = v.cross(DVec3::Y).normalize();
    glam::DQuat::from_axis_angle(horizontal, degrees.to_radians()) * v
}

/// One (view, sun) pair's mesh verdicts: the summed response of the foliage the eye sees, and
/// the part of it the sun reaches.
#[derive(Clone, Copy, Default)]
struct Seen {
    response: f64,
    lit: f64,
}

/// A foliage surface a view ray meets first in the mesh: its normal facing the eye, and the
/// origin a ray leaving it may start from (off the surface by its error bound, on the eye's
/// side, which is the side a lit leaf is lit from), and the ray's key.
struct LeafHit {
    normal: Vec3,
    point: Vec3,
    error: Vec3,
    key: u64,
}

/// The foliage the rays along `-v` from `rays` see first in the mesh.
fn mesh_leaves(
    tracer: &MeshTracer,
    (corners, is_foliage): (&[[Vec3; 3]], &[bool]),
    rays: &[(DVec3, f64)],
    v: DVec3,
    view: u64,
) -> Vec<LeafHit> {
    rays.par_iter()
        .enumerate()
        .filter_map(|(i, &(o, t_end))| {
            let key = rng::hash3(view, i as u64, rng::purpose::CALIBRATION);
            let ray = Ray {
                origin: o.as_vec3(),
                dir: -v.as_vec3(),
            };
            let (t, hit) = tracer.nearest(&ray, 0.0, t_end as f32, key)?;
            if !is_foliage[t as usize] {
                return None;
            }
            let c = corners[t as usize];
            let n = (c[1] - c[0]).cross(c[2] - c[0]).normalize_or_zero();
            let (point, error) = barycentric_point(c, hit.w);
            Some(LeafHit {
                normal: if n.dot(v.as_vec3()) < 0.0 { -n } else { n },
                point,
                error,
                key,
            })
        })
        .collect()
}

/// What the sun towards `l` does to `leaves`: their summed Lambert response, and the part of it
/// an alpha-tested shadow ray finds unblocked.
fn mesh_seen(tracer: &MeshTracer, leaves: &[LeafHit], l: DVec3) -> Seen {
    let l = l.as_vec3();
    leaves
        .par_iter()
        .map(|leaf| {
            let response = f64::from(leaf.normal.dot(l).max(0.0));
            if response == 0.0 {
                return Seen::default();
            }
            let shadow = Ray {
                origin: offset_origin(leaf.point, leaf.error, leaf.normal, l),
                dir: l,
            };
            let hidden = tracer.occluded(&shadow, 0.0, f32::INFINITY, rng::mix64(leaf.key));
            Seen {
                response,
                lit: if hidden { 0.0 } else { response },
            }
        })
        .reduce(Seen::default, |a, b| Seen {
            response: a.response + b.response,
            lit: a.lit + b.lit,
        })
}

/// The level's extinction `[wood, foliage]` at model-space point `p`, times `factor` (the
/// extinction scale and the directional factor) and each part's `turn`; inside a solid,
/// opaque in its part.
fn extinction(
    level: &Sparse,
    origin: DVec3,
    p: DVec3,
    (factor, turn): (f64, [f32; 2]),
) -> [f64; 2] {
    let c = (p - origin) / level.cell;
    let c = Vec3::new(c.x as f32, c.y as f32, c.z as f32);
    if level.in_solid(c, 1.0) {
        let [w, f] = level.solid_parts_at(c);
        let opaque = f64::from(SOLID_EXTINCTION);
        return if f > w { [0.0, opaque] } else { [opaque, 0.0] };
    }
    let [wood, foliage] = level.density_at(c);
    [wood * turn[0], foliage * turn[1]].map(|x| f64::from(x) * factor)
}

/// One sample of a view ray's march: where, the share of the ray's light it holds
/// (`T (1 - exp(-sigma dt))`), and its extinction by part.
struct ViewSample {
    p: DVec3,
    weight: f64,
    sigma: [f64; 2],
}

/// The view ray `o - t v` marched through the level (the midpoint rule of [`midpoints`]),
/// each part's extinction times its `turn` (`[1, 1]`, or the renderer's
/// [`PartFacing::along`] the ray).
fn march_view(
    level: &Sparse,
    (origin, scale): (DVec3, f64),
    (o, v): (DVec3, DVec3),
    turn: [f32; 2],
) -> Vec<ViewSample> {
    let d = -v;
    let factor = scale * f64::from(level.directional_factor(d.as_vec3()));
    let (ts, step) = midpoints(level, origin, o, d);
    let mut transmittance = 1.0f64;
    let mut samples = Vec::new();
    for t in ts {
        let p = o + d * t;
        let sigma = extinction(level, origin, p, (factor, turn));
        let opacity = -(-(sigma[0] + sigma[1]) * step).exp_m1();
        if opacity > 0.0 {
            samples.push(ViewSample {
                p,
                weight: transmittance * opacity,
                sigma,
            });
        }
        transmittance *= 1.0 - opacity;
    }
    samples
}

/// The chance that the foliage scatters a sample, the wood's extinction weighted by `w`.
pub fn foliage_chance(sigma: [f64; 2], w: f64) -> f64 {
    let wood = w * sigma[0];
    if wood + sigma[1] > 0.0 {
        sigma[1] / (wood + sigma[1])
    } else {
        0.0
    }
}

/// Optical depth from a leaf at `p` along `d` to the level's box, per unit extinction scale,
/// as the renderer marches the leaf's own tree (`render::sunlight`): on a level with solids
/// the first cell is left out (the layer of surfaces the leaf stands for, a solid's surface
/// and the rims on it), and a solid beyond stops the light whatever the factor (infinite).
/// The factor scales the density alone: fitted with the solids' opacity inside the depth, it
/// scaled that too (the Kenney trees' levels with solids read factors near 1e-18, which
/// made their solids' extinction of 1e18 about one), and the renderer never does.
fn depth_from(level: &Sparse, origin: DVec3, p: DVec3, d: DVec3, factor: f64) -> f64 {
    let (ts, step) = midpoints(level, origin, p, d);
    if step == 0.0 {
        return 0.0;
    }
    let solid = level.has_solid();
    let mut depth = 0.0;
    for t in ts.filter(|&t| !solid || t >= level.cell) {
        let c = ((p + d * t - origin) / level.cell).as_vec3();
        if solid && level.in_solid(c, 1.0) {
            return f64::INFINITY;
        }
        let [wood, foliage] = level.density_at(c).map(|x| f64::from(x) * factor);
        depth += wood + foliage;
    }
    depth * step
}

/// A point of a level's foliage that a view ray's light comes from: its weight, where it is,
/// and the leaf normals the renderer shades it with (the visible normals of its leaves'
/// distribution, seen along the view), whose response to a sun weights its shadow as the
/// renderer weights it.
struct Drawn {
    weight: f64,
    p: DVec3,
    normals: [Vec3; EVEN],
}

impl Drawn {
    /// The mean Lambert response of the point's leaves to the sun towards `l`.
    fn response(&self, l: Vec3) -> f64 {
        let sum: f32 = self.normals.iter().map(|n| n.dot(l).max(0.0)).sum();
        f64::from(sum) / EVEN as f64
    }
}

/// The level's foliage samples of one view ray that carry its shadows: `POINTS_PER_RAY`
/// points drawn from the samples' weights times the chance that the foliage scatters there,
/// as the renderer chooses: by the cells' chances of showing wood (`chances`,
/// `Level::wood_chances` of the level's [`wood_shown`]) where it has them, else with the wood
/// weighted by `wood`; each part turned, in its extinction and its chance, by `turn`
/// ([`PartFacing::along`] the ray, as the renderer's view rays turn it).
fn texture_points(
    level: &Sparse,
    (origin, scale, wood, chances): (DVec3, f64, f64, &[f32]),
    (o, v, turn): (DVec3, DVec3, [f32; 2]),
    key: u64,
) -> Vec<Drawn> {
    let chance = |s: &ViewSample| match s.sigma {
        [w, f] if w > 0.0 && f > 0.0 && !chances.is_empty() => {
            // The directional factor scales both parts alike, so it cancels; each part's
            // turn does not.
            let [wood, foliage] = level.shown_at(chances, (s.p - origin) / level.cell);
            let [wood, foliage] = [f64::from(wood * turn[0]), f64::from(foliage * turn[1])];
            foliage / (wood + foliage)
        }
        sigma => foliage_chance(sigma, wood),
    };
    let weights: Vec<(DVec3, f64)> = march_view(level, (origin, scale), (o, v), turn)
        .iter()
        .map(|s| (s.p, s.weight * chance(s)))
        .collect();
    let total: f64 = weights.iter().map(|w| w.1).sum();
    if total <= 0.0 {
        return Vec::new();
    }
    (0..POINTS_PER_RAY)
        .map(|j| {
            let u = (j as f64 + rng::unit(rng::hash3(key, j as u64, 0))) / POINTS_PER_RAY as f64;
            let mut acc = 0.0;
            let p = weights
                .iter()
                .find(|w| {
                    acc += w.1;
                    acc >= u * total
                })
                .map_or(weights[weights.len() - 1].0, |w| w.0);
            let c = ((p - origin) / level.level.cell).as_vec3();
            let leaves = level
                .level
                .foliage_leaves(c)
                .map_or(ISOTROPIC_LEAVES, |(_, m)| m);
            Drawn {
                weight: total / POINTS_PER_RAY as f64,
                p,
                normals: VisibleNormals::new(leaves, v.as_vec3()).even(),
            }
        })
        .collect()
}

/// The factor `k` in `[0, K_MAX]` with `sum W exp(-k tau) / sum W = visible`; 1 where there is
/// nothing to fit. A point behind a solid (`tau` infinite) is dark whatever `k`.
fn fit(points: &[(f64, f64)], visible: f64) -> f64 {
    let total: f64 = points.iter().map(|p| p.0).sum();
    if total <= 0.0 || !visible.is_finite() {
        return 1.0;
    }
    // The mean visibility and its slope, convex and decreasing in k.
    let mean = |k: f64| {
        let (m, slope) = points.iter().fold((0.0, 0.0), |(m, slope), &(w, tau)| {
            if tau.is_infinite() {
                return (m, slope);
            }
            let e = w * (-k * tau).exp();
            (m + e, slope - tau * e)
        });
        (m / total, slope / total)
    };
    if mean(0.0).0 <= visible {
        return 0.0;
    }
    if mean(K_MAX).0 >= visible {
        return K_MAX;
    }
    newton_bracketed(mean, visible, (0.0, K_MAX), 0.0)
}

/// What a level must show and shadow to look like its mesh (see the module's documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sight {
    /// The weight on the wood's extinction in choosing which part scatters.
    pub wood_weight: f32,
    /// The self-shadowing factors.
    pub self_shadow: SelfShadow,
}

/// Bounds of the wood weight: a factor of 64 either way.
const WOOD_WEIGHT: (f64, f64) = (1.0 / 64.0, 64.0);

/// Each level's [`Sight`], fitted to `mesh` (`is_foliage` per triangle), and where the tree
/// has both parts each level's [`wood_shown`] (empty otherwise). `origin` is the grid's
/// corner, `extinction_scale` turns density into extinction. A tree with only one part gets
/// the neutral weight 1; one without foliage, self-shadowing 1.
pub fn fit_sight(
    mesh: &Mesh,
    is_foliage: &[bool],
    levels: &[Level],
    origin: DVec3,
    extinction_scale: f64,
) -> (Vec<Sight>, Vec<Vec<f32>>) {
    let tracer = MeshTracer::new(mesh);
    let coarsest = levels.last().expect("a mip chain has levels");
    let hi = origin + DVec3::from(coarsest.dims.map(|d| d as f64)) * coarsest.cell;
    let spacing = levels[0].cell * RAY_SPACING;
    let mesh_spacing = levels[0].cell * MESH_RAY_SPACING;
    let levels: Vec<Sparse> = levels.iter().map(Sparse::new).collect();
    let levels = levels.as_slice();
    let rays = |v: DVec3, pair: u64| super::calibrate::lattice(origin, hi, -v, spacing, pair);
    let mesh_rays =
        |v: DVec3, pair: u64| super::calibrate::lattice(origin, hi, -v, mesh_spacing, pair);
    let weights = wood_weights(
        &tracer,
        is_foliage,
        levels,
        (origin, extinction_scale),
        &rays,
    );
    let both = is_foliage.iter().any(|&f| f) && is_foliage.iter().any(|&f| !f);
    let shown = if both {
        wood_shown(&tracer, is_foliage, levels, (origin, hi))
    } else {
        vec![Vec::new(); levels.len()]
    };
    let factors = if is_foliage.iter().any(|&f| f) {
        self_shadow_factors(
            &tracer,
            (&mesh.corners(), is_foliage),
            levels,
            (origin, extinction_scale),
            (&weights, &shown),
            (&rays, &mesh_rays),
        )
    } else {
        vec![SelfShadow::NONE; levels.len()]
    };
    let sights: Vec<Sight> = weights
        .iter()
        .zip(factors)
        .map(|(&w, self_shadow)| Sight {
            wood_weight: w as f32,
            self_shadow,
        })
        .collect();
    if std::env::var("TEXEL_DEBUG_CALIBRATION").is_ok() {
        for (n, s) in sights.iter().enumerate() {
            eprintln!("level {n}: {s:?} (self-shadowing at {SELF_SHADOW_ANGLES:?} degrees)");
        }
    }
    (sights, shown)
}

/// The wood weight of every level: the wood's share of what the views see in the mesh (first
/// hits), matched by the level's samples, both parts read alike along every view as the
/// readers that use the weight (before texel 1.7) read them. 1 where the mesh shows only one
/// part.
fn wood_weights(
    tracer: &MeshTracer,
    is_foliage: &[bool],
    levels: &[Sparse],
    (origin, scale): (DVec3, f64),
    rays: Lattice,
) -> Vec<f64> {
    let views = views();
    let mut hits = [0u64; 2];
    // Per level: the weight of samples of wood alone, of all samples, and the mixed ones.
    let mut pure = vec![(0.0f64, 0.0f64); levels.len()];
    let mut mixed: Vec<Vec<(f64, [f64; 2])>> = vec![Vec::new(); levels.len()];
    for (k, &v) in views.iter().enumerate() {
        let rays = rays(v, k as u64);
        for (i, &(o, t_end)) in rays.iter().enumerate() {
            let ray = Ray {
                origin: o.as_vec3(),
                dir: -v.as_vec3(),
            };
            let key = rng::hash3(k as u64, i as u64, rng::purpose::CALIBRATION);
            if let Some((t, _)) = tracer.nearest(&ray, 0.0, t_end as f32, key) {
                hits[usize::from(is_foliage[t as usize])] += 1;
            }
        }
        for (n, level) in levels.iter().enumerate() {
            let samples: Vec<ViewSample> = rays
                .par_iter()
                .flat_map_iter(|&(o, _)| march_view(level, (origin, scale), (o, v), [1.0; 2]))
                .collect();
            for sample in samples {
                pure[n].1 += sample.weight;
                match sample.sigma {
                    [w, 0.0] if w > 0.0 => pure[n].0 += sample.weight,
                    [0.0, _] => {}
                    sigma => mixed[n].push((sample.weight, sigma)),
                }
            }
        }
    }
    if hits[0] == 0 || hits[1] == 0 {
        return vec![1.0; levels.len()];
    }
    let target = hits[0] as f64 / (hits[0] + hits[1]) as f64;
    pure.iter()
        .zip(&mixed)
        .map(|(&(wood, total), mixed)| {
            let share = |w: f64| {
                let m: f64 = mixed
                    .iter()
                    .map(|&(weight, sigma)| weight * (1.0 - foliage_chance(sigma, w)))
                    .sum();
                (wood + m) / total
            };
            bisect_log(share, target, WOOD_WEIGHT)
        })
        .collect()
}

/// Spacing of the rays that find which part the mesh shows first in each cell, in level-0
/// cells: four rays a view through every level-0 cell's face.
const SHOWN_RAY_SPACING: f64 = 0.5;
/// Hits the mesh gives a cell's share before its own count outweighs the prior (the share a
/// uniform mixture of the cell's densities would show).
const SHOWN_PRIOR: f64 = 4.0;
/// Most surfaces one ray walks through (a hostile mesh of stacked cards has millions).
const SHOWN_MAX_HITS: usize = 1024;
/// The first of the random streams that place the rays of [`wood_shown`], one per view: apart
/// from the other fits' lattices, which are keyed by the view's index alone.
const SHOWN_STREAM: u64 = 1000;

/// Every level's wood density as it counts in choosing which part scatters (texel 1.7): per
/// cell, the density times the weight that makes a uniform mixture of the cell's two densities
/// show wood first as often as the mesh does within the cell. A ray meeting a cell of wood of
/// extinction `a` and foliage `b` mixed uniformly meets wood first with chance `a / (a + b)`,
/// wherever it enters; in the mesh the leaves sit outside the branches they grow on, and a
/// crown's cell shows its leaves and hides its twigs. For each of the 12 views, rays half a
/// level-0 cell apart walk every surface of the mesh in turn; the first surface a ray meets in
/// a cell counts for that cell's share `h`, on every level. The weight `w` solves
/// `w a / (w a + b) = h`, with `h` drawn towards `a / (a + b)` by [`SHOWN_PRIOR`] hits and `w`
/// within [`WOOD_WEIGHT`]; a cell of one part keeps its density (the choice is certain). Where
/// the renderer turns the parts unlike along the views (`volume::PartFacing`: flat leaves
/// show less of themselves from the side than upright branches do), the hits are kept by view
/// and `w` makes the chances the renderer gives each view, summed, the mesh's
/// ([`shown_density`]): a share pooled over the views and met with the parts unturned is not
/// what the renderer shows along any of them.
///
/// Unlike a level's single weight fitted to what whole views of the lone tree see, the share is
/// the cell's own: the same wherever the cell stands in a forest, whose neighbours hide the
/// trunk and the crown's underside that a lone tree's views show. `(origin, hi)` is the box
/// the levels cover (the grid's corner and the coarsest level's far corner).
pub fn wood_shown(
    tracer: &MeshTracer,
    is_foliage: &[bool],
    levels: &[Sparse],
    (origin, hi): (DVec3, DVec3),
) -> Vec<Vec<f32>> {
    let Some(finest) = levels.first() else {
        return Vec::new();
    };
    let spacing = finest.cell * SHOWN_RAY_SPACING;
    let views = views();
    // Only a cell with both parts has a choice to fit: per level, each cell's slot among
    // those (`u32::MAX` for the others), and per slot the first hits on wood and on foliage
    // in each view.
    let slots: Vec<Vec<u32>> = levels
        .iter()
        .map(|l| {
            let [wood, foliage] = &l.density;
            let mut next = 0u32;
            (0..l.cell_count())
                .map(|i| {
                    if wood[i] > 0.0 && foliage[i] > 0.0 {
                        next += 1;
                        next - 1
                    } else {
                        u32::MAX
                    }
                })
                .collect()
        })
        .collect();
    let mut hits: Vec<Vec<[u32; 2]>> = slots
        .iter()
        .map(|s| {
            let mixed = s.iter().filter(|&&k| k != u32::MAX).count();
            vec![[0; 2]; mixed * views.len()]
        })
        .collect();
    for (k, &v) in views.iter().enumerate() {
        let stream = SHOWN_STREAM + k as u64;
        let rays = super::calibrate::lattice(origin, hi, -v, spacing, stream);
        let firsts: Vec<Vec<(u8, u32, bool)>> = rays
            .par_iter()
            .enumerate()
            .map(|(i, &(o, t_end))| {
                let key = rng::hash3(stream, i as u64, rng::purpose::CALIBRATION);
                first_in_cells(tracer, is_foliage, levels, origin, (o, -v, t_end), key)
            })
            .collect();
        for (n, cell, foliage) in firsts.into_iter().flatten() {
            let slot = slots[n as usize][cell as usize];
            if slot != u32::MAX {
                hits[n as usize][slot as usize * views.len() + k][usize::from(foliage)] += 1;
            }
        }
    }
    levels
        .iter()
        .zip(slots.iter().zip(&hits))
        .map(|(level, (slots, hits))| {
            // The renderer turns each part along a view alike in every cell of a level.
            let facing = PartFacing::of(level);
            let ratios: Vec<f64> = views
                .iter()
                .map(|&v| {
                    let [wood, foliage] = facing.along(v.as_vec3());
                    f64::from(wood) / f64::from(foliage)
                })
                .collect();
            let [wood, foliage] = &level.density;
            (0..level.cell_count())
                .map(|i| match slots[i] {
                    u32::MAX => wood[i],
                    slot => {
                        let by_view = slot as usize * views.len();
                        let hits = &hits[by_view..by_view + views.len()];
                        shown_density(wood[i], foliage[i], hits, &ratios)
                    }
                })
                .collect()
        })
        .collect()
}

/// A cell's shown wood density from its densities and the mesh's first hits in it
/// ([`wood_shown`]), given per view: the hits on wood and on foliage, and the ratio of the
/// wood's turn to the foliage's along that view ([`PartFacing::along`]).
///
/// The renderer shows wood first in the cell, along a view whose ratio is `r`, with chance
/// `c_r(w) = w a r / (w a r + b)`; the weight makes the views' summed chances, each times
/// the view's hits, plus the prior's [`SHOWN_PRIOR`] hits at the uniform share `a / (a + b)`
/// (ratio 1), the mesh's wood hits plus the prior's: `sum_v n_v c_(r_v)(w) + P c_1(w) =
/// h_wood + P a / (a + b)`. Where every ratio is 1 that is `c_1(w) = h`, solved in closed
/// form.
fn shown_density(wood: f32, foliage: f32, hits: &[[u32; 2]], ratios: &[f64]) -> f32 {
    if wood <= 0.0 || foliage <= 0.0 {
        return wood;
    }
    let (a, b) = (f64::from(wood), f64::from(foliage));
    let uniform = a / (a + b);
    let hw: u32 = hits.iter().map(|h| h[0]).sum();
    let target = f64::from(hw) + SHOWN_PRIOR * uniform;
    let w = if ratios.iter().all(|&r| r == 1.0) {
        let hf: u32 = hits.iter().map(|h| h[1]).sum();
        let h = target / (f64::from(hw + hf) + SHOWN_PRIOR);
        (h * b / ((1.0 - h) * a)).clamp(WOOD_WEIGHT.0, WOOD_WEIGHT.1)
    } else {
        let chance = |w: f64, r: f64| w * a * r / (w * a * r + b);
        let shown = |w: f64| {
            hits.iter()
                .zip(ratios)
                .map(|(&[hw, hf], &r)| f64::from(hw + hf) * chance(w, r))
                .sum::<f64>()
                + SHOWN_PRIOR * chance(w, 1.0)
        };
        bisect_log(shown, target, WOOD_WEIGHT)
    };
    (w * a) as f32
}

/// The first surface the ray `(o, d, t_end)` meets in each cell of each level it crosses, as
/// (level, cell, whether foliage): a straight ray crosses a cell once, so a hit in another
/// cell than the hit before it is that cell's first.
fn first_in_cells(
    tracer: &MeshTracer,
    is_foliage: &[bool],
    levels: &[Sparse],
    origin: DVec3,
    (o, d, t_end): (DVec3, DVec3, f64),
    key: u64,
) -> Vec<(u8, u32, bool)> {
    let ray = Ray {
        origin: o.as_vec3(),
        dir: d.as_vec3(),
    };
    let mut last = vec![u32::MAX; levels.len()];
    let mut out = Vec::new();
    let mut t = 0.0f32;
    for _ in 0..SHOWN_MAX_HITS {
        let Some((tri, hit)) = tracer.nearest(&ray, t, t_end as f32, key) else {
            break;
        };
        t = hit.t;
        let p = o + d * f64::from(hit.t);
        for (n, level) in levels.iter().enumerate() {
            let c = (p - origin) / level.cell;
            let cell = c.floor();
            let inside = (0..3).all(|a| cell[a] >= 0.0 && (cell[a] as usize) < level.dims[a]);
            if !inside {
                continue;
            }
            let index = level.index(cell.x as usize, cell.y as usize, cell.z as usize) as u32;
            if index != last[n] {
                last[n] = index;
                out.push((n as u8, index, is_foliage[tri as usize]));
            }
        }
    }
    out
}

/// Suns per view and angle, turned about the view direction a quarter apart (one at angle 0,
/// where they coincide): every view has suns at the turns the rows by eye height and sun turn
/// are kept at (0, 90 and 180 degrees). (Before stop 54 every other view's were turned an
/// eighth further, to give the rows by sun height, which the renderer reads only where a file
/// has no rows by view, more heights; those views' suns then fed no node.)
const SUNS_PER_ANGLE: usize = 4;

/// The suns at `angle` degrees from the view `v` that stand above the horizon: `v` turned up
/// by the angle, then about `v` by quarter turns.
fn suns(v: DVec3, angle: f64) -> Vec<DVec3> {
    if angle == 0.0 {
        return vec![v];
    }
    let up = turned_up(v, angle);
    (0..SUNS_PER_ANGLE)
        .map(|j| {
            let about = (360.0 * j as f64 / SUNS_PER_ANGLE as f64).to_radians();
            glam::DQuat::from_axis_angle(v, about) * up
        })
        .filter(|l| l.y >= 0.0)
        .collect()
}

/// The weight the sun `l` seen along the view `v` gives each row of a level's fit: 1 for the
/// pooled row; for the rows by sun height the weights by which the renderer interpolates
/// between them (a tent one spacing wide either side of each node), so that a row pools the
/// suns near it; and 1 for the row by eye height and sun turn whose node the view and the sun
/// stand at, 0 for the others. The renderer interpolates between those nodes, and a node
/// fitted to the suns around it too was pulled towards its neighbours': a low eye's node with
/// the sun beside it (near the horizon) towards the suns 45 degrees higher, whose shadows are
/// shorter (the fixture conifer seen from 10 degrees up, sun 60 degrees from the eye beside
/// it: 0.89 of the mesh's sunlit share so pooled, 0.995 fitted at the node).
fn row_weights(v: DVec3, l: DVec3) -> [f64; ROWS] {
    let s = SunFromEye::new(v.as_vec3(), l.as_vec3());
    let mut w = [0.0; ROWS];
    w[0] = 1.0;
    for (w, h) in w[1..].iter_mut().zip(hat(&SUN_HEIGHTS, s.sun_height)) {
        *w = f64::from(h);
    }
    let (eye, turn) = (hat(&EYE_HEIGHTS, s.eye_height), hat(&SUN_TURNS, s.turn));
    for (e, we) in eye.iter().enumerate() {
        for (t, wt) in turn.iter().enumerate() {
            // At a node to within rounding: the views stand at the eye heights' nodes and
            // every view has suns at the turns' nodes.
            let at_node = we * wt > 0.999;
            w[BY_VIEW + e * SUN_TURNS.len() + t] = if at_node { 1.0 } else { 0.0 };
        }
    }
    w
}

/// What one view gives every angle and sun: the foliage its rays see first in the mesh, and per
/// level the points drawn from each ray's foliage samples.
struct ViewDraws {
    leaves: Vec<LeafHit>,
    drawn: Vec<Vec<Drawn>>,
}

/// The rows a fit makes: the pooled one, one per sun height, then (from [`BY_VIEW`]) one per
/// eye height and sun turn, the turns running fastest.
const ROWS: usize = BY_VIEW + EYE_HEIGHTS.len() * SUN_TURNS.len();
/// The first of the rows by eye height and sun turn.
const BY_VIEW: usize = 1 + SUN_HEIGHTS.len();

/// Every level's self-shadowing factors (pooled, per sun height, per eye height and sun turn),
/// one per angle of [`SELF_SHADOW_ANGLES`], with the levels' shown wood (or, where a level
/// has none, its wood weight) deciding which samples are foliage, as the renderer decides.
/// Each view's rays, the leaves they meet in the mesh and the points drawn in each level serve
/// every angle and sun.
fn self_shadow_factors(
    tracer: &MeshTracer,
    mesh: (&[[Vec3; 3]], &[bool]),
    levels: &[Sparse],
    (origin, scale): (DVec3, f64),
    (wood_weights, shown): (&[f64], &[Vec<f32>]),
    (rays, mesh_rays): (Lattice, Lattice),
) -> Vec<SelfShadow> {
    let views = views();
    // Worked out once per level, as the renderer keeps them.
    let chances: Vec<Vec<f32>> = levels
        .iter()
        .zip(shown)
        .map(|(level, shown)| level.wood_chances(shown))
        .collect();
    let facing: Vec<PartFacing> = levels.iter().map(|l| PartFacing::of(l)).collect();
    let draws: Vec<ViewDraws> = views
        .iter()
        .enumerate()
        .map(|(k, &v)| {
            let leaves = mesh_leaves(tracer, mesh, &mesh_rays(v, k as u64), v, k as u64);
            let rays = rays(v, k as u64);
            let drawn = levels
                .iter()
                .enumerate()
                .map(|(n, level)| {
                    let turn = facing[n].along(v.as_vec3());
                    rays.par_iter()
                        .enumerate()
                        .flat_map_iter(|(i, &(o, _))| {
                            let key = rng::hash3(k as u64, i as u64, rng::purpose::SELF_SHADOW);
                            texture_points(
                                level,
                                (origin, scale, wood_weights[n], &chances[n]),
                                (o, v, turn),
                                key,
                            )
                        })
                        .collect()
                })
                .collect();
            ViewDraws { leaves, drawn }
        })
        .collect();
    // Per level and row, the factors at each angle.
    let mut factors = vec![[[1.0f32; SELF_SHADOW_ANGLES.len()]; ROWS]; levels.len()];
    for (a, &angle) in SELF_SHADOW_ANGLES.iter().enumerate() {
        let mut seen = [Seen::default(); ROWS];
        // Per level and row: (weight, optical depth towards the sun) of the drawn points.
        let mut points: Vec<[Vec<(f64, f64)>; ROWS]> =
            (0..levels.len()).map(|_| Default::default()).collect();
        for (&v, ViewDraws { leaves, drawn }) in views.iter().zip(&draws) {
            // With the sun straight behind the leaves the eye sees (180 degrees), none is lit
            // and nothing depends on the factor: that angle is not measured.
            let suns = if angle < 180.0 {
                suns(v, f64::from(angle))
            } else {
                Vec::new()
            };
            for l in suns {
                let weights = row_weights(v, l);
                let s = mesh_seen(tracer, leaves, l);
                for (row, &w) in weights.iter().enumerate().filter(|(_, w)| **w > 0.0) {
                    seen[row].response += w * s.response;
                    seen[row].lit += w * s.lit;
                }
                let sun = l.as_vec3();
                for (n, level) in levels.iter().enumerate() {
                    let factor = scale * f64::from(level.directional_factor(sun));
                    // A point whose leaves all face away from the sun weighs nothing: its
                    // shadow is not marched, nor kept.
                    let depths: Vec<(f64, f64)> = drawn[n]
                        .par_iter()
                        .filter_map(|d| {
                            let w = d.weight * d.response(sun);
                            (w > 0.0).then(|| (w, depth_from(level, origin, d.p, l, factor)))
                        })
                        .collect();
                    for (row, &w) in weights.iter().enumerate().filter(|(_, w)| **w > 0.0) {
                        points[n][row].extend(depths.iter().map(|&(x, tau)| (w * x, tau)));
                    }
                }
            }
        }
        for (f, points) in factors.iter_mut().zip(&points) {
            for row in 0..ROWS {
                f[row][a] = if seen[row].response > 0.0 {
                    fit(&points[row], seen[row].lit / seen[row].response) as f32
                } else if seen[0].response > 0.0 {
                    // A height or view no sun came near at this angle (the hot spot's suns
                    // stand only as high as the views; a low eye's suns below its line of
                    // sight are under the horizon): the pooled factor.
                    f[0][a]
                } else if a > 0 {
                    // Where the eye sees no lit foliage, the previous angle's (smooth).
                    f[row][a - 1]
                } else {
                    1.0
                };
            }
        }
    }
    factors
        .iter()
        .map(|f| SelfShadow {
            pooled: f[0],
            by_height: std::array::from_fn(|h| f[1 + h]),
            by_view: Some(std::array::from_fn(|e| {
                std::array::from_fn(|t| f[BY_VIEW + e * SUN_TURNS.len() + t])
            })),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cell's shown wood: the uniform mixture's where the mesh agrees with it or where no ray
    /// met the cell, less where its leaves hide its wood, more where its wood is outside, and
    /// the density itself where the cell holds one part.
    #[test]
    fn a_cells_shown_wood_follows_its_first_hits() {
        let (a, b) = (1.0f32, 3.0f32);
        let alike = |hits: [u32; 2]| shown_density(a, b, &[hits], &[1.0]);
        assert!((alike([100, 300]) - a).abs() < 1e-6);
        assert_eq!(alike([0, 0]), a);
        let hidden = alike([1, 399]);
        assert!(hidden < 0.05 * a && hidden >= a / 64.0, "{hidden}");
        let outside = alike([399, 1]);
        assert!(outside > 20.0 * a && outside <= 64.0 * a, "{outside}");
        // The share it gives is the mesh's, drawn towards the mixture's by four hits.
        let w = f64::from(alike([30, 10]));
        let h = (30.0 + SHOWN_PRIOR * 0.25) / (40.0 + SHOWN_PRIOR);
        assert!((w / (w + 3.0) - h).abs() < 1e-6, "{w}");
        assert_eq!(shown_density(0.0, b, &[[5, 5]], &[1.0]), 0.0);
        assert_eq!(shown_density(a, 0.0, &[[5, 5]], &[1.0]), a);
    }

    /// Where the renderer turns the parts unlike along the views, the shown wood makes the
    /// wood it shows first, summed over the views, the mesh's: from the side (the wood's turn
    /// twice the foliage's) the mesh shows wood in 30 of 40 hits, from above (half) in 2 of
    /// 40. The fit's chances, each view's read as the renderer reads it and with the prior's 4
    /// hits at the uniform share (1/4), sum to the mesh's 32 wood hits (and the prior's). A
    /// cell seen only from the side, where the renderer doubles the wood's odds, shows about
    /// half the wood the closed form for parts turned alike would give it.
    #[test]
    fn a_cells_shown_wood_sums_to_the_meshs_over_views_as_the_renderer_turns_them() {
        let (a, b) = (1.0f64, 3.0f64);
        let chance = |w: f64, r: f64| w * r / (w * r + b);
        let w = f64::from(shown_density(
            a as f32,
            b as f32,
            &[[30, 10], [2, 38]],
            &[2.0, 0.5],
        ));
        let summed = 40.0 * chance(w, 2.0) + 40.0 * chance(w, 0.5) + SHOWN_PRIOR * chance(w, 1.0);
        let target = 32.0 + SHOWN_PRIOR * a / (a + b);
        assert!((summed - target).abs() < 1e-6, "{summed} against {target}");

        let side = f64::from(shown_density(a as f32, b as f32, &[[20, 20]], &[2.0]));
        let alike = f64::from(shown_density(a as f32, b as f32, &[[20, 20]], &[1.0]));
        let summed = 40.0 * chance(side, 2.0) + SHOWN_PRIOR * chance(side, 1.0);
        assert!((summed - (20.0 + 1.0)).abs() < 1e-6, "{summed}");
        assert!(
            (0.45..0.6).contains(&(side / alike)),
            "{side} against {alike}"
        );
    }

    /// Wood inside a closed shell of leaves in one cell is never met first: the cell shows
    /// (almost) no wood; turned inside out, (almost) only wood. Either way on every level.
    #[test]
    fn wood_behind_leaves_is_not_shown() {
        use crate::import::AlphaMode;
        use crate::render::mesh_tests::{cuboid, material, quads};
        let outer = cuboid(Vec3::splat(0.3), Vec3::splat(1.7));
        let inner = cuboid(Vec3::splat(0.7), Vec3::splat(1.3));
        let mut level = Level::empty([1, 1, 1], 2.0);
        level.density = [vec![1.0], vec![1.0]];
        let mut coarse = Level::empty([1, 1, 1], 4.0);
        coarse.density = [vec![1.0], vec![1.0]];
        let levels = [level, coarse];
        let levels: Vec<Sparse> = levels.iter().map(Sparse::new).collect();
        let mesh = quads(
            &[outer, inner].concat(),
            material("part", 0.5, 1.0, AlphaMode::Opaque),
        );
        let tracer = MeshTracer::new(&mesh);
        for outer_is_foliage in [true, false] {
            let is_foliage: Vec<bool> = (0..24).map(|t| (t < 12) == outer_is_foliage).collect();
            let shown = wood_shown(
                &tracer,
                &is_foliage,
                &levels,
                (DVec3::ZERO, DVec3::splat(4.0)),
            );
            for s in shown {
                let s = s[0];
                // The uniform mixture's is 1; the prior's four hits keep it off the bounds.
                if outer_is_foliage {
                    assert!(s < 0.1, "hidden wood shows: {s}");
                } else {
                    assert!(s > 10.0, "wood outside is hidden: {s}");
                }
            }
        }
    }

    /// The fitted factor gives the target visibility, and the ends clamp.
    #[test]
    fn the_factor_gives_the_visibility() {
        let points = [(1.0, 0.0), (2.0, 0.5), (1.0, 3.0)];
        for visible in [0.3, 0.6, 0.9] {
            let k = fit(&points, visible);
            let got: f64 = points.iter().map(|&(w, t)| w * (-k * t).exp()).sum::<f64>() / 4.0;
            assert!((got - visible).abs() < 1e-9, "{k}: {got}");
        }
        assert_eq!(fit(&points, 1.0), 0.0);
        assert_eq!(fit(&points, 0.0), K_MAX);
        assert_eq!(fit(&[], 0.5), 1.0);
    }

    /// The suns of a view are at the stated angle from it, above the horizon, and at angles
    /// below 180 degrees there is at least one (up to eight, one at the hot spot).
    #[test]
    fn suns_are_at_the_angle() {
        for v in views() {
            assert!((v.length() - 1.0).abs() < 1e-12);
            for angle in SELF_SHADOW_ANGLES.map(f64::from) {
                let suns = suns(v, angle);
                let most = if angle == 0.0 { 1 } else { SUNS_PER_ANGLE };
                assert!(suns.len() <= most, "{angle}: {}", suns.len());
                assert!(angle == 180.0 || !suns.is_empty(), "{angle}");
                for l in suns {
                    let want = angle.to_radians().cos();
                    assert!((v.dot(l) - want).abs() < 1e-12, "{angle}: {}", v.dot(l));
                    assert!((l.length() - 1.0).abs() < 1e-12);
                    assert!(l.y >= 0.0);
                }
            }
        }
    }

    /// Every view's suns at the turns of [`SUN_TURNS`] count in the one row by eye height and
    /// sun turn of their node, with weight 1; the suns between the nodes in none.
    #[test]
    fn the_rows_by_view_take_the_suns_at_their_nodes() {
        for v in views() {
            for angle in [15.0, 30.0, 60.0, 90.0] {
                for l in suns(v, angle) {
                    let turn = SunFromEye::new(v.as_vec3(), l.as_vec3()).turn;
                    let w = row_weights(v, l);
                    let by_view = &w[BY_VIEW..];
                    let at_node = SUN_TURNS.iter().any(|&t| (t - turn).abs() < 0.1);
                    let ones = by_view.iter().filter(|&&x| x == 1.0).count();
                    assert_eq!(
                        ones,
                        usize::from(at_node),
                        "{v} {angle} {turn}: {by_view:?}"
                    );
                    assert!(by_view.iter().all(|&x| x == 0.0 || x == 1.0));
                }
            }
        }
    }
}
