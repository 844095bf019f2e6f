//! Directional extinction per mip level: a matrix per level that makes the level cast, in
//! every direction, the silhouette its mesh casts.
//!
//! Two approximations make a texture's whole-tree silhouette differ from its mesh's, and both
//! depend on direction:
//!
//! - **Anisotropy.** Level 0 holds one isotropic extinction per cell, combined from the three
//!   axes' scans. Flat leaves and whorled needles block more light from above than from the
//!   side; an isotropic cell cannot, so the texture loses coverage from above (-11 % for a
//!   real pine) and gains it from the side. Trilinear interpolation widens silhouettes too
//!   (+6 % to +11 % over random views).
//! - **Mip correlation.** A coarse cell lets through what its children let through on
//!   average, but a column of coarse cells mixes fine columns that the fine level keeps apart
//!   (the gaps through a crown line up; the averages do not), so coarse levels block more of
//!   the tree (+26 % to +88 % at the coarsest).
//!
//! So each level carries a symmetric positive-definite matrix `S`, and extinction along a unit
//! direction `w` is the stored extinction times `sqrt(w^T S w)`. That is the projected-area
//! law of an SGGX microflake distribution (Heitz, Dupuy, Crassin and Dachsbacher 2015), with
//! one matrix shared by every cell of a level: the directional part of Ross's G-function of
//! the whole crown at that level's scale. `S` = identity is the isotropic texture.
//!
//! The fit: along each of 13 directions (the axes, the face diagonals and the body diagonals;
//! a silhouette is the same seen from either side), the same lattice of parallel rays is
//! traced through the mesh (alpha-tested, as the renderer's mesh method does) and marched
//! through the level's trilinear texture, each part's density turned by how much of its
//! surfaces face the rays (`volume::PartFacing`), as the renderer's view rays turn it (a
//! crown's flat leaves block more from above than its upright branches do; the matrix
//! carries what the parts share). The factor `f` whose blocked area, the sum over rays
//! of `1 - exp(-f depth)`, equals the mesh's is found by bisection; then `S` is the least
//! squares solution of `w^T S w = f^2` over the 13 directions (linear in the six entries of
//! `S`), exact along the axes when the data allow.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::geom::Ray;
use crate::import::Mesh;
use crate::mesh_tracer::MeshTracer;
use crate::rng;
use crate::volume::{DIRECTIONAL_FLOOR, Level, PartFacing, Sparse};

/// Factors are kept within these bounds (a direction nothing blocks keeps 1).
const F_MIN: f64 = 1.0 / 64.0;
const F_MAX: f64 = 64.0;
/// Weight of the three axes against each diagonal in the least squares fit.
const AXIS_WEIGHT: f64 = 100.0;
/// Rays per level-0 cell edge across the view.
const RAYS_PER_CELL: f64 = 3.0;
/// The mesh's rays per texture ray along each side of a ray's square (see [`mesh_area`]).
const MESH_OVERSAMPLE: f64 = 3.0;
/// Lattice streams of the mesh's rays start here (the texture's are the directions' indices).
const MESH_STREAMS: u64 = 1 << 16;
/// March samples per cell of the level marched.
const SAMPLES_PER_CELL: f64 = 2.0;

/// The 13 directions, unit length: axes, face diagonals, body diagonals.
pub(super) fn directions() -> Vec<DVec3> {
    let mut d = vec![DVec3::X, DVec3::Y, DVec3::Z];
    for (a, b) in [(0, 1), (0, 2), (1, 2)] {
        for s in [1.0, -1.0] {
            let mut v = DVec3::ZERO;
            v[a] = 1.0;
            v[b] = s;
            d.push(v.normalize());
        }
    }
    for (sy, sz) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
        d.push(DVec3::new(1.0, sy, sz).normalize());
    }
    d
}

/// The matrices of every level (upper triangle `[S_xx, S_yy, S_zz, S_xy, S_xz, S_yz]`): each
/// level made to block, in every direction, the area `mesh` blocks. `origin` is the grid's
/// corner; `extinction_scale` turns density into extinction.
pub fn directional_forms(
    mesh: &Mesh,
    levels: &[Level],
    origin: DVec3,
    extinction_scale: f64,
) -> Vec<[f32; 7]> {
    let tracer = MeshTracer::new(mesh);
    let coarsest = levels.last().expect("a mip chain has levels");
    let hi = origin + DVec3::from(coarsest.dims.map(|d| d as f64)) * coarsest.cell;
    let spacing = levels[0].cell / RAYS_PER_CELL;
    let sparse: Vec<Sparse> = levels.iter().map(Sparse::new).collect();
    let facing: Vec<PartFacing> = levels.iter().map(PartFacing::of).collect();
    let dirs = directions();
    // Per direction: the area the mesh blocks, in texture rays' squares, and per level the
    // texture rays' depths.
    let traced: Vec<(f64, Vec<Vec<f64>>)> = dirs
        .iter()
        .enumerate()
        .map(|(k, &d)| {
            let rays = lattice(origin, hi, d, spacing, k as u64);
            // Each part as much as faces the rays, as the renderer's view rays turn it.
            let turns: Vec<[f32; 2]> = facing.iter().map(|f| f.along(d.as_vec3())).collect();
            let depths: Vec<Vec<f64>> = rays
                .par_iter()
                .map(|&(o, _)| {
                    sparse
                        .iter()
                        .zip(&turns)
                        .map(|(l, &turn)| depth(l, origin, (o, d), turn) * extinction_scale)
                        .collect()
                })
                .collect();
            let by_level = (0..levels.len())
                .map(|l| depths.iter().map(|r| r[l]).collect())
                .collect();
            (mesh_area(&tracer, (origin, hi), d, spacing, k), by_level)
        })
        .collect();
    (0..levels.len())
        .map(|l| {
            let factors: Vec<f64> = traced
                .iter()
                .map(|(area, by_level)| fit(&by_level[l], *area))
                .collect();
            if std::env::var("TEXEL_DEBUG_CALIBRATION").is_ok() {
                eprintln!(
                    "level {l}: factors {:?}",
                    factors
                        .iter()
                        .map(|f| (f * 1000.0).round() / 1000.0)
                        .collect::<Vec<_>>()
                );
            }
            solve(&dirs, &factors)
        })
        .collect()
}

/// The area `mesh` blocks seen along `d` over the box `lo..hi`, in units of `spacing^2`: hits
/// of rays `MESH_OVERSAMPLE^2` times as dense as the texture's. The texture's blocked area is
/// smooth and needs few rays; the mesh's hit or miss is what is noisy (thin branches seen end
/// on), and its rays are cheap: at the texture's density the fitted factors of a bare tree
/// varied by 7 % from one lattice to the next.
fn mesh_area(
    tracer: &MeshTracer,
    (lo, hi): (DVec3, DVec3),
    d: DVec3,
    spacing: f64,
    k: usize,
) -> f64 {
    let fine = spacing / MESH_OVERSAMPLE;
    let rays = lattice(lo, hi, d, fine, MESH_STREAMS + k as u64);
    let hits = rays
        .par_iter()
        .enumerate()
        .filter(|&(i, &(o, t_end))| {
            let ray = Ray {
                origin: o.as_vec3(),
                dir: d.as_vec3(),
            };
            let key = rng::hash3(i as u64, 0, rng::purpose::CALIBRATION);
            tracer.occluded(&ray, 0.0, t_end as f32, key)
        })
        .count();
    hits as f64 / (MESH_OVERSAMPLE * MESH_OVERSAMPLE)
}

/// The squares of side `spacing` over the shadow of the box `lo..hi` along `d`, as the
/// parallel rays of a fit cross it: `na x nb` of them, and where a ray through a point of
/// them starts (before the box) and how far it runs (past it).
pub(super) struct Shadow {
    d: DVec3,
    e1: DVec3,
    e2: DVec3,
    centre: DVec3,
    radius: f64,
    a0: f64,
    b0: f64,
    spacing: f64,
    pub(super) na: usize,
    pub(super) nb: usize,
}

impl Shadow {
    pub(super) fn new(lo: DVec3, hi: DVec3, d: DVec3, spacing: f64) -> Shadow {
        let helper = if d.y.abs() < 0.9 { DVec3::Y } else { DVec3::X };
        let e1 = d.cross(helper).normalize();
        let e2 = d.cross(e1);
        let centre = (lo + hi) * 0.5;
        let corners =
            crate::geom::box_corners(lo.to_array(), hi.to_array()).map(|c| DVec3::from(c) - centre);
        let span = |e: DVec3| {
            corners
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), c| {
                    (a.min(c.dot(e)), b.max(c.dot(e)))
                })
        };
        let ((a0, a1), (b0, b1)) = (span(e1), span(e2));
        Shadow {
            d,
            e1,
            e2,
            centre,
            radius: (hi - lo).length() * 0.5,
            a0,
            b0,
            spacing,
            na: ((a1 - a0) / spacing).ceil() as usize,
            nb: ((b1 - b0) / spacing).ceil() as usize,
        }
    }

    /// The origin of the ray through the point `(x, y)` squares from the shadow's corner.
    pub(super) fn start(&self, x: f64, y: f64) -> DVec3 {
        let (a, b) = (self.a0 + x * self.spacing, self.b0 + y * self.spacing);
        self.centre + self.e1 * a + self.e2 * b - self.d * (self.radius + 1.0)
    }

    /// How far a ray runs from its origin to beyond the box.
    pub(super) fn length(&self) -> f64 {
        2.0 * (self.radius + 1.0)
    }
}

/// Parallel rays along `d`, one at a random point of each square of side `spacing` over the
/// box `lo..hi`'s shadow (stratified, so thin axis-aligned branches do not alias with a
/// regular lattice), each as (origin before the box, parameter after it). `stream` keys the
/// random points.
pub(super) fn lattice(
    lo: DVec3,
    hi: DVec3,
    d: DVec3,
    spacing: f64,
    stream: u64,
) -> Vec<(DVec3, f64)> {
    let shadow = Shadow::new(lo, hi, d, spacing);
    let na = shadow.na;
    let mut rays = Vec::with_capacity(na * shadow.nb);
    for j in 0..shadow.nb {
        for i in 0..na {
            let key = rng::hash3(stream, (i + na * j) as u64, rng::purpose::CALIBRATION);
            let x = i as f64 + rng::unit(key);
            let y = j as f64 + rng::unit(rng::mix64(key));
            rays.push((shadow.start(x, y), shadow.length()));
        }
    }
    rays
}

/// Optical depth per unit extinction scale of the ray `o + t d` through `level`'s trilinear
/// densities, each part times its `turn` ([`PartFacing::along`] `d`), by the midpoint rule of
/// [`midpoints`]; infinite where the ray meets a solid, which blocks it whatever the
/// directional factor.
fn depth(
    level: &Sparse,
    origin: DVec3,
    (o, d): (DVec3, DVec3),
    [to_wood, to_foliage]: [f32; 2],
) -> f64 {
    let start = (o - origin) / level.cell;
    let dc = d / level.cell;
    let (ts, step) = midpoints(level, origin, o, d);
    if step == 0.0 {
        return 0.0;
    }
    let mut sum = 0.0;
    for t in ts {
        let c = start + dc * t;
        let c = Vec3::new(c.x as f32, c.y as f32, c.z as f32);
        if level.in_solid(c, 1.0) {
            return f64::INFINITY;
        }
        let [wood, foliage] = level.density_at(c);
        sum += f64::from(wood * to_wood + foliage * to_foliage);
    }
    sum * step
}

/// The midpoints `t` of equal steps of at most `1 / SAMPLES_PER_CELL` of a cell between where
/// `o + t d` enters and leaves the level's box, and the step: density jumps from zero at the
/// box's faces and is continuous inside, so the steps must start and end there. No points
/// where the ray misses the box.
pub(super) fn midpoints(
    level: &Level,
    origin: DVec3,
    o: DVec3,
    d: DVec3,
) -> (impl Iterator<Item = f64>, f64) {
    let (t0, t1) = box_interval(level, origin, o, d);
    let (n, step) = if t1 <= t0 {
        (0, 0.0)
    } else {
        let n = ((t1 - t0) / (level.cell / SAMPLES_PER_CELL))
            .ceil()
            .max(1.0);
        (n as usize, (t1 - t0) / n)
    };
    ((0..n).map(move |s| t0 + (s as f64 + 0.5) * step), step)
}

/// The factor `f` in [F_MIN, F_MAX] whose blocked count, the sum over rays of
/// `1 - exp(-f depth)`, is `target`; 1 where nothing blocks or nothing should.
///
/// The count is increasing and concave in `f`, so Newton's method from below climbs to the
/// root without overshooting; a step from above that lands below `F_MIN` or past the bracket
/// is replaced by bisection. A handful of steps reach full precision where bisection took 50,
/// each a pass over every ray.
fn fit(depths: &[f64], target: f64) -> f64 {
    // Rays that miss the texture add exactly 0 whatever f, and rays a solid blocks exactly 1:
    // the passes need not visit either, and the others must block what the solids leave.
    let solid = depths.iter().filter(|d| d.is_infinite()).count() as f64;
    if target <= 0.0 {
        return 1.0;
    }
    let target = target - solid;
    let depths: Vec<f64> = depths
        .iter()
        .copied()
        .filter(|&d| d != 0.0 && d.is_finite())
        .collect();
    let blocked = |f: f64| {
        depths.iter().fold((0.0, 0.0), |(b, slope), &d| {
            let e = (-f * d).exp();
            (b + (1.0 - e), slope + d * e)
        })
    };
    if blocked(1.0).0 <= 0.0 {
        return 1.0;
    }
    if target <= 0.0 {
        // The solids block all the mesh does, or more: the rest as little as it may.
        return F_MIN;
    }
    if blocked(F_MAX).0 <= target {
        return F_MAX;
    }
    if blocked(F_MIN).0 >= target {
        return F_MIN;
    }
    newton_bracketed(blocked, target, (F_MIN, F_MAX), 1.0)
}

/// The `x` in the bracket `(lo, hi)` where `g`, monotone there and returning its value and
/// slope, equals `target` (`g(lo)` and `g(hi)` on either side of it), starting from `x`: Newton
/// steps, each replaced by the bracket's geometric middle when it would leave the bracket.
/// For the convex or concave counts of the fits a handful of passes reach full precision
/// where bisection took 50.
pub(super) fn newton_bracketed(
    g: impl Fn(f64) -> (f64, f64),
    target: f64,
    (mut lo, mut hi): (f64, f64),
    mut x: f64,
) -> f64 {
    let increasing = g(hi).0 > g(lo).0;
    for _ in 0..100 {
        let (v, slope) = g(x);
        if (v < target) == increasing {
            lo = x;
        } else {
            hi = x;
        }
        let newton = x + (target - v) / slope;
        let next = if slope != 0.0 && newton > lo && newton < hi {
            newton
        } else if lo > 0.0 {
            (lo * hi).sqrt()
        } else {
            0.5 * (lo + hi)
        };
        if (next - x).abs() <= 1e-12 * x.abs().max(1e-300) {
            return next;
        }
        x = next;
    }
    x
}

/// The parameter interval `(t0, t1)` of `o + t d` inside the level's box (empty if `t1 <= t0`).
fn box_interval(level: &Level, origin: DVec3, o: DVec3, d: DVec3) -> (f64, f64) {
    let size = DVec3::from(level.dims.map(|n| n as f64)) * level.cell;
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < origin[a] || o[a] > origin[a] + size[a] {
                return (0.0, 0.0);
            }
            continue;
        }
        let (near, far) = (
            (origin[a] - o[a]) / d[a],
            (origin[a] + size[a] - o[a]) / d[a],
        );
        t0 = t0.max(near.min(far));
        t1 = t1.min(near.max(far));
    }
    (t0, t1)
}

/// The `x` in `[lo, hi]` where the increasing `f` reaches `target`, by bisection on `ln x`
/// (an end where `target` lies beyond it).
pub(super) fn bisect_log(f: impl Fn(f64) -> f64, target: f64, (lo, hi): (f64, f64)) -> f64 {
    if f(hi) <= target {
        return hi;
    }
    if f(lo) >= target {
        return lo;
    }
    let (mut a, mut b) = (lo.ln(), hi.ln());
    for _ in 0..50 {
        let mid = 0.5 * (a + b);
        if f(mid.exp()) < target {
            a = mid;
        } else {
            b = mid;
        }
    }
    (0.5 * (a + b)).exp()
}

/// The entries `[S_xx, S_yy, S_zz, S_xy, S_xz, S_yz, c]` whose `q(w)` (see
/// [`crate::volume::Level::directional_factor`]) best matches `f^2` along each direction `w`,
/// in the weighted least squares sense; where that is not [`admissible`], the axes' squared
/// factors on the diagonal, which always pass.
fn solve(dirs: &[DVec3], factors: &[f64]) -> [f32; 7] {
    let row = |w: DVec3| {
        [
            w.x * w.x,
            w.y * w.y,
            w.z * w.z,
            2.0 * w.x * w.y,
            2.0 * w.x * w.z,
            2.0 * w.y * w.z,
            w.x.powi(4) + w.y.powi(4) + w.z.powi(4),
        ]
    };
    // Weighted normal equations (A^T W A) s = A^T W b, the axes weighted up so that they come
    // out (nearly) exact: they are the views a forest is most often seen and lit along.
    let mut m = [[0.0f64; 8]; 7];
    for (k, (w, f)) in dirs.iter().zip(factors).enumerate() {
        let weight = if k < 3 { AXIS_WEIGHT } else { 1.0 };
        let r = row(*w);
        for i in 0..7 {
            for j in 0..7 {
                m[i][j] += weight * r[i] * r[j];
            }
            m[i][7] += weight * r[i] * f * f;
        }
    }
    let axes = [0, 1, 2].map(|a| factors[a] * factors[a]);
    let fallback = [axes[0], axes[1], axes[2], 0.0, 0.0, 0.0, 0.0];
    let s = gauss(m).filter(admissible).unwrap_or(fallback);
    s.map(|v| v as f32)
}

/// Gauss-Jordan elimination with partial pivoting on an augmented 7 x 8 system.
fn gauss(mut m: [[f64; 8]; 7]) -> Option<[f64; 7]> {
    for c in 0..7 {
        let p = (c..7).max_by(|&a, &b| m[a][c].abs().total_cmp(&m[b][c].abs()))?;
        if m[p][c].abs() < 1e-12 {
            return None;
        }
        m.swap(c, p);
        for r in 0..7 {
            if r != c {
                let k = m[r][c] / m[c][c];
                for j in c..8 {
                    m[r][j] -= k * m[c][j];
                }
            }
        }
    }
    Some(std::array::from_fn(|i| m[i][7] / m[i][i]))
}

/// Whether the form's entries are within what the format holds (`F_MAX^2`) and it keeps `q(w)`
/// at or above the floor the renderer clamps to, checked over
/// 2,000 directions spread evenly over the sphere (a Fibonacci lattice): a fit that dips below
/// it somewhere would be clamped there, and is not used.
fn admissible(s: &[f64; 7]) -> bool {
    // Entries the format holds, and no near-cancellation of a huge quadratic and quartic part
    // (an ill-conditioned fit), which f32 would evaluate badly.
    let bound = F_MAX * F_MAX;
    if !s.iter().all(|v| v.is_finite() && v.abs() <= bound) {
        return false;
    }
    let level = Level {
        directional: s.map(|v| v as f32),
        ..Level::empty([1, 1, 1], 1.0)
    };
    // The factor squared, above the clamp, is q itself.
    crate::geom::sphere_lattice(2000).all(|w| {
        let f = level.directional_factor(w);
        f * f > DIRECTIONAL_FLOOR * 1.0001
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Least squares recovers an admissible form from exact factors along the 13 directions,
    /// and falls back to the axes' diagonal where the data are no admissible form's.
    #[test]
    fn the_matrix_fitted_to_exact_factors_is_the_matrix() {
        let s = [1.2f64, 0.6, 0.9, 0.2, -0.1, 0.05, -0.3];
        let dirs = directions();
        let level = Level {
            directional: s.map(|v| v as f32),
            ..Level::empty([1, 1, 1], 1.0)
        };
        let factors: Vec<f64> = dirs
            .iter()
            .map(|&w| f64::from(level.directional_factor(w.as_vec3())))
            .collect();
        let got = solve(&dirs, &factors);
        for i in 0..7 {
            assert!((f64::from(got[i]) - s[i]).abs() < 1e-4, "{got:?}");
        }
        // Factors no admissible form gives: huge along one diagonal only.
        let mut odd = vec![1.0; 13];
        odd[3] = 30.0;
        let got = solve(&dirs, &odd);
        assert!(admissible(&got.map(f64::from)), "{got:?}");
    }

    /// The fitted factor makes the rays block exactly the target.
    #[test]
    fn the_factor_blocks_the_target() {
        let depths = [0.0, 0.1, 0.5, 2.0, 0.0];
        for target in [0.3, 1.0, 2.5] {
            let f = fit(&depths, target);
            let blocked: f64 = depths.iter().map(|d| 1.0 - (-f * d).exp()).sum();
            assert!((blocked - target).abs() < 1e-9, "{f} {blocked}");
        }
        assert_eq!(fit(&depths, 0.0), 1.0);
        assert_eq!(fit(&[0.0; 3], 1.0), 1.0);
        assert_eq!(fit(&depths, 10.0), F_MAX);
    }
}
