//! Scan conversion along one axis (the paper's section 2): a bundle of parallel rays, one through
//! every fine cell centre, crosses the model; each ray's sorted surface crossings give
//!
//! * the transmittance of every texture cell the bundle crosses, in both directions,
//! * the surface colour met inside each texture cell (for the albedo), of the surfaces that
//!   can be seen: not those inside the union of the closed parts,
//! * the second moment of each part's surface normals inside each cell, each crossing
//!   weighted by `1 / (|n_x| + |n_y| + |n_z|)`: a surface is crossed by the rays of axis `a` in
//!   proportion to its area times `|n_a|`, so over the three axes the weights sum to the area,
//!   whatever the orientation (the normal distributions the renderer shades foliage and wood
//!   with),
//! * optionally, the fine-scale solid occupancy along the ray (nonzero winding of closed parts)
//!   and the fine cells a surface crosses.
//!
//! Rays are parallel to a grid axis, so finding which rays a triangle covers is 2D
//! rasterisation of its projection. Vertices are snapped to 1/256 of a fine cell and edge
//! functions are evaluated in exact integer arithmetic with a top-left fill rule, so a ray through
//! an edge or vertex shared by two triangles hits exactly one of them: closed meshes stay
//! watertight, which the winding count depends on.
//!
//! Work is split by texture column (the `k` x `k` rays crossing one column of texture cells);
//! each column is computed by one task from its own inputs, so results do not depend on the
//! number of threads.

use glam::DVec3;
use rayon::prelude::*;

use super::grid::Grid;
use crate::import::{AlphaMode, Mesh};
use crate::rng;

/// Sub-fine-cell precision of the fixed-point rasteriser.
const SUBPIXEL: f64 = 256.0;

/// Bits of a fine cell in [`AxisScan::fine`].
pub const INSIDE_ALL: u8 = 1;
pub const INSIDE_WOOD: u8 = 2;
pub const SURFACE_ALL: u8 = 4;
pub const SURFACE_WOOD: u8 = 8;

/// The scan's view of the model: triangles in fine-cell units relative to the grid origin.
pub struct ScanModel<'a> {
    pub mesh: &'a Mesh,
    pub grid: Grid,
    /// Triangle vertices in fine-cell units from the grid origin.
    pub corners: Vec<[DVec3; 3]>,
    pub is_foliage: Vec<bool>,
    pub is_closed: Vec<bool>,
    /// The triangles the rays cross; the others are not there for this scan.
    pub drawn: Vec<bool>,
}

impl<'a> ScanModel<'a> {
    pub fn new(mesh: &'a Mesh, grid: Grid, is_foliage: Vec<bool>, is_closed: Vec<bool>) -> Self {
        let h = grid.fine_cell();
        let corners: Vec<[DVec3; 3]> = mesh
            .triangles
            .iter()
            .map(|t| {
                t.vertices
                    .map(|v| (mesh.positions[v as usize].as_dvec3() - grid.origin) / h)
            })
            .collect();
        let drawn = vec![true; corners.len()];
        ScanModel {
            mesh,
            grid,
            corners,
            is_foliage,
            is_closed,
            drawn,
        }
    }

    /// The same model with only the triangles `keep` marks.
    pub fn only(&self, keep: &[bool]) -> ScanModel<'a> {
        ScanModel {
            mesh: self.mesh,
            grid: self.grid,
            corners: self.corners.clone(),
            is_foliage: self.is_foliage.clone(),
            is_closed: self.is_closed.clone(),
            drawn: keep.to_vec(),
        }
    }
}

/// What the rays along one axis saw, per texture cell. Cells are indexed `[column][l]`: `column
/// = cu + dims[u] * cv` over the two transverse axes and `l` the cell along the axis.
pub struct AxisScan {
    /// Extinction (1/m) estimated along this axis for all surfaces (`[0]`) and wood alone
    /// (`[1]`); `None` where every ray was blocked before reaching the cell from both sides.
    pub sigma: [Vec<Option<f32>>; 2],
    /// Sum of linear RGB over the surface crossings inside the cell that can be seen (outside
    /// every closed part), and their count: wood `[0]`, foliage `[1]`.
    pub color_sum: [Vec<[f32; 3]>; 2],
    pub crossings: [Vec<u32>; 2],
    /// Area-weighted sums of `n n^T` (`[xx, yy, zz, xy, xz, yz]`) over each part's crossings
    /// inside the cell, and of their weights: wood `[0]` (only the surfaces that can be seen,
    /// as for colour), foliage `[1]` (every leaf).
    pub normal_sum: [Vec<[f32; 6]>; 2],
    pub normal_weight: [Vec<f32>; 2],
    /// Per column, rays that cross no surface at all (`[0]`) and no wood (`[1]`).
    pub misses: [Vec<u32>; 2],
    /// Fine-cell bits (`INSIDE_*`, `SURFACE_*`), `[column][ray][fine cell along the axis]`, with
    /// `ray = ru + k * rv`; empty unless occupancy was asked for.
    pub fine: Vec<u8>,
}

#[derive(Clone, Copy)]
struct Crossing {
    /// Distance along the axis, fine-cell units.
    t: f64,
    triangle: u32,
    /// +1 entering a closed part, -1 leaving it, 0 for an open surface.
    winding: i8,
    is_foliage: bool,
    rgb: [f32; 3],
    /// The triangle's unit normal (either orientation: only `n n^T` is used).
    normal: [f32; 3],
}

/// A column's results before they are gathered into the [`AxisScan`].
struct Column {
    sigma: [Vec<Option<f32>>; 2],
    color_sum: [Vec<[f32; 3]>; 2],
    crossings: [Vec<u32>; 2],
    normal_sum: [Vec<[f32; 6]>; 2],
    normal_weight: [Vec<f32>; 2],
    misses: [u32; 2],
    fine: Vec<u8>,
}

/// The bits (`INSIDE_*`, `SURFACE_*`) the three axes' scans (made with occupancy) hold for
/// the fine cell `f`, along x, y and z: where each axis's layout of [`AxisScan::fine`] keeps it.
pub fn fine_bits(grid: &Grid, scans: &[AxisScan], f: [usize; 3]) -> [u8; 3] {
    let (k, fine) = (grid.k, grid.fine_dims());
    [0, 1, 2].map(|a| {
        let (u, v) = ((a + 1) % 3, (a + 2) % 3);
        let column = f[u] / k + grid.dims[u] * (f[v] / k);
        let ray = f[u] % k + k * (f[v] % k);
        scans[a].fine[(column * k * k + ray) * fine[a] + f[a]]
    })
}

/// Most crossings one ray may have, on average over the rays of a column. A column's rays
/// collect their crossings all at once, 40 bytes each, in each thread: at the default 8 x 8
/// rays a column, this bound holds a column to 4.2 million (160 MiB, up to twice that while
/// its lists grow). A real model's rays cross far fewer surfaces: the fixtures' densest column
/// averages 253 per ray by the bound [`scan_axis`] checks, the shared real models' 445. A
/// model that draws one mesh many times at one place (a scene whose nodes pile copies of it,
/// within `--max-triangles`) has every copy cross every ray there: a thousand copies of a
/// 1,000-triangle strip took 1.5 GB. Finer rays (`--fine` over `--resolution`) hold more
/// crossings a column, as the settings ask.
pub const MAX_RAY_CROSSINGS: u64 = 1 << 16;

/// A column whose rays would cross more than [`MAX_RAY_CROSSINGS`] surfaces each, on average.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "one column of cells along {axis} holds {triangles} triangles, which could cross each of \
     its rays {crossings} times on average, over the limit of {MAX_RAY_CROSSINGS}: the model \
     piles surfaces on one spot (a mesh drawn many times at one place?)"
)]
pub struct PiledError {
    pub axis: char,
    pub triangles: usize,
    pub crossings: u64,
}

/// Scans along `axis` (0 = x, 1 = y, 2 = z).
pub fn scan_axis(model: &ScanModel, axis: usize, occupancy: bool) -> Result<AxisScan, PiledError> {
    let grid = &model.grid;
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let columns_u = grid.dims[u];
    let columns = columns_u * grid.dims[v];
    let bins = bin_triangles(model, axis);
    // Before any crossing is kept: at most, each triangle crosses every ray of a column that
    // its projection's box covers.
    let (crossings, triangles) = (0..columns)
        .into_par_iter()
        .map(|column| {
            let (cu, cv) = (column % columns_u, column / columns_u);
            let bound = bins[column]
                .iter()
                .map(|&t| rays_covered(model, axis, t, [cu, cv]))
                .sum::<u64>();
            (bound, bins[column].len())
        })
        .max()
        .unwrap_or((0, 0));
    let per_ray = crossings / (grid.k * grid.k) as u64;
    if per_ray > MAX_RAY_CROSSINGS {
        return Err(PiledError {
            axis: ['x', 'y', 'z'][axis],
            triangles,
            crossings: per_ray,
        });
    }
    let results: Vec<Column> = (0..columns)
        .into_par_iter()
        .map_init(
            || vec![Vec::new(); grid.k * grid.k],
            |rays, column| {
                let (cu, cv) = (column % columns_u, column / columns_u);
                scan_column(model, axis, [cu, cv], &bins[column], rays, occupancy)
            },
        )
        .collect();

    let mut scan = AxisScan {
        sigma: [Vec::new(), Vec::new()],
        color_sum: [Vec::new(), Vec::new()],
        crossings: [Vec::new(), Vec::new()],
        normal_sum: [Vec::new(), Vec::new()],
        normal_weight: [Vec::new(), Vec::new()],
        misses: [Vec::new(), Vec::new()],
        fine: Vec::new(),
    };
    for c in results {
        for s in 0..2 {
            scan.sigma[s].extend_from_slice(&c.sigma[s]);
            scan.color_sum[s].extend_from_slice(&c.color_sum[s]);
            scan.crossings[s].extend_from_slice(&c.crossings[s]);
            scan.misses[s].push(c.misses[s]);
        }
        for part in 0..2 {
            scan.normal_sum[part].extend_from_slice(&c.normal_sum[part]);
            scan.normal_weight[part].extend_from_slice(&c.normal_weight[part]);
        }
        scan.fine.extend_from_slice(&c.fine);
    }
    Ok(scan)
}

/// How many of column `[cu, cv]`'s rays the box of triangle `t`'s projection covers (the
/// rasteriser, snapping corners to 1/256 of a ray's spacing, may take one more at an edge).
fn rays_covered(model: &ScanModel, axis: usize, t: u32, [cu, cv]: [usize; 2]) -> u64 {
    let k = model.grid.k;
    let Some(rays) = ray_box(model, axis, t) else {
        return 0;
    };
    let within = |(a, b): (usize, usize), first: usize| {
        let (a, b) = (a.max(first), b.min(first + k - 1));
        if a <= b { (b - a + 1) as u64 } else { 0 }
    };
    within(rays[0], cu * k) * within(rays[1], cv * k)
}

/// Triangles whose projection covers at least one ray of each column.
fn bin_triangles(model: &ScanModel, axis: usize) -> Vec<Vec<u32>> {
    let grid = &model.grid;
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let k = grid.k;
    let mut bins = vec![Vec::new(); grid.dims[u] * grid.dims[v]];
    for t in 0..model.corners.len() {
        if !model.drawn[t] {
            continue;
        }
        let Some([(i0, i1), (j0, j1)]) = ray_box(model, axis, t as u32) else {
            continue;
        };
        for cv in j0 / k..=j1 / k {
            for cu in i0 / k..=i1 / k {
                bins[cu + grid.dims[u] * cv].push(t as u32);
            }
        }
    }
    bins
}

/// The rays (fine indices along u and v, inclusive) that the box of triangle `t`'s projection
/// along `axis` covers; `None` where it covers none.
fn ray_box(model: &ScanModel, axis: usize, t: u32) -> Option<[(usize, usize); 2]> {
    let fine = model.grid.fine_dims();
    let c = &model.corners[t as usize];
    let range = |d: usize| {
        let lo = c[0][d].min(c[1][d]).min(c[2][d]);
        let hi = c[0][d].max(c[1][d]).max(c[2][d]);
        // Rays sit at fine-cell centres i + 0.5.
        ray_range(lo, hi, fine[d])
    };
    Some([range((axis + 1) % 3)?, range((axis + 2) % 3)?])
}

fn ray_range(lo: f64, hi: f64, n: usize) -> Option<(usize, usize)> {
    let first = (lo - 0.5).ceil().max(0.0);
    let last = (hi - 0.5).floor().min(n as f64 - 1.0);
    (first <= last).then_some((first as usize, last as usize))
}

fn scan_column(
    model: &ScanModel,
    axis: usize,
    [cu, cv]: [usize; 2],
    triangles: &[u32],
    rays: &mut [Vec<Crossing>],
    occupancy: bool,
) -> Column {
    let grid = &model.grid;
    let k = grid.k;
    for r in rays.iter_mut() {
        r.clear();
    }
    for &t in triangles {
        rasterize(model, axis, t, [cu * k, cv * k], rays);
    }

    let cells = grid.dims[axis];
    let fine_along = cells * k;
    // Histograms of the cell holding each ray's first and last crossing, all surfaces and wood.
    let mut first = [vec![0u32; cells], vec![0u32; cells]];
    let mut last = [vec![0u32; cells], vec![0u32; cells]];
    let mut misses = [0u32; 2];
    let mut color_sum = [vec![[0.0f32; 3]; cells], vec![[0.0f32; 3]; cells]];
    let mut crossings = [vec![0u32; cells], vec![0u32; cells]];
    let mut normal_sum = [vec![[0.0f32; 6]; cells], vec![[0.0f32; 6]; cells]];
    let mut normal_weight = [vec![0.0f32; cells], vec![0.0f32; cells]];
    let mut fine = if occupancy {
        vec![0u8; k * k * fine_along]
    } else {
        Vec::new()
    };
    let cell_of = |t: f64| ((t / k as f64).floor().max(0.0) as usize).min(cells - 1);

    for (r, hits) in rays.iter_mut().enumerate() {
        hits.sort_unstable_by(|a, b| a.t.total_cmp(&b.t).then(a.triangle.cmp(&b.triangle)));
        match (hits.first(), hits.last()) {
            (Some(a), Some(b)) => {
                first[0][cell_of(a.t)] += 1;
                last[0][cell_of(b.t)] += 1;
            }
            _ => misses[0] += 1,
        }
        let mut wood = hits.iter().filter(|h| !h.is_foliage);
        match (wood.next(), hits.iter().rev().find(|h| !h.is_foliage)) {
            (Some(a), Some(b)) => {
                first[1][cell_of(a.t)] += 1;
                last[1][cell_of(b.t)] += 1;
            }
            _ => misses[1] += 1,
        }
        // A surface inside the union of the closed parts (a trunk running up into a solid
        // crown, the faces where two solids meet, a card inside a trunk) is seen from nowhere:
        // the mesh never shows its colour, so neither does the cell's albedo. Only where the
        // ray's windings add up (a watertight crossing) can inside be told from outside.
        let watertight = hits.iter().map(|h| i32::from(h.winding)).sum::<i32>() == 0;
        let mut winding = 0i32;
        for h in hits.iter() {
            let before = winding;
            winding += i32::from(h.winding);
            let (l, part) = (cell_of(h.t), h.is_foliage as usize);
            let seen = !(watertight && before != 0 && winding != 0);
            if seen {
                let sum = &mut color_sum[part][l];
                for c in 0..3 {
                    sum[c] += h.rgb[c];
                }
                crossings[part][l] += 1;
            }
            if h.is_foliage || seen {
                let n = glam::Vec3::from(h.normal);
                let w = 1.0 / n.abs().element_sum();
                for (sum, m) in normal_sum[part][l]
                    .iter_mut()
                    .zip(crate::volume::normal_moment(n))
                {
                    *sum += w * m;
                }
                normal_weight[part][l] += w;
            }
        }
        if occupancy {
            mark_fine(hits, &mut fine[r * fine_along..(r + 1) * fine_along]);
        }
    }

    let rays_per_column = (k * k) as u32;
    let h = grid.cell;
    let sigma =
        [0, 1].map(|s| conditional_extinction(&first[s], &last[s], misses[s], rays_per_column, h));
    Column {
        sigma,
        color_sum,
        crossings,
        normal_sum,
        normal_weight,
        misses,
        fine,
    }
}

/// Extinction of each cell along a column from where the bundle's rays are first blocked.
///
/// Going in the + direction, `T+(l)` = (rays still unblocked leaving cell l) / (rays unblocked
/// entering it); likewise `T-` going the other way. The product of `T+` over the column
/// telescopes to exactly the fraction of rays that cross the whole column, so the optical depth
/// of every axis-aligned column matches the mesh; averaging the two directions keeps that sum
/// while removing the bias of choosing one. A cell no ray reaches from a side contributes
/// nothing from that side (`None` when neither side reaches it). A cell that stops every ray
/// gets the largest extinction `k` x `k` rays can resolve: transmittance 1 / (2 k^2).
fn conditional_extinction(
    first: &[u32],
    last: &[u32],
    misses: u32,
    rays: u32,
    cell: f64,
) -> Vec<Option<f32>> {
    let n = first.len();
    let floor = 1.0 / (2.0 * rays as f64);
    let sigma = |entering: u32, leaving: u32| -> Option<f64> {
        (entering > 0).then(|| -(leaving as f64 / entering as f64).max(floor).ln() / cell)
    };
    let mut plus = vec![None; n];
    let mut unblocked = rays; // rays entering cell l going +
    for l in 0..n {
        let leaving = unblocked - first[l];
        plus[l] = sigma(unblocked, leaving);
        unblocked = leaving;
    }
    debug_assert_eq!(unblocked, misses);
    let mut out = vec![None; n];
    let mut unblocked = rays;
    for l in (0..n).rev() {
        let leaving = unblocked - last[l];
        let minus = sigma(unblocked, leaving);
        out[l] = match (plus[l], minus) {
            (Some(a), Some(b)) => Some(0.5 * (a + b)),
            (a, b) => a.or(b),
        }
        .map(|s| s as f32);
        unblocked = leaving;
    }
    out
}

/// Fine cells along one ray: inside a closed part (nonzero winding at the cell centre), or
/// crossed by a surface. A ray whose winding does not return to zero passed through a hole in a
/// supposedly closed part; its inside flags are dropped rather than smeared to the grid's end.
fn mark_fine(hits: &[Crossing], fine: &mut [u8]) {
    let n = fine.len();
    for h in hits {
        let f = (h.t.floor().max(0.0) as usize).min(n - 1);
        fine[f] |= if h.is_foliage {
            SURFACE_ALL
        } else {
            SURFACE_ALL | SURFACE_WOOD
        };
    }
    for (bit, wood_only) in [(INSIDE_ALL, false), (INSIDE_WOOD, true)] {
        let relevant = || {
            hits.iter()
                .filter(|h| h.winding != 0 && !(wood_only && h.is_foliage))
        };
        if relevant().map(|h| h.winding as i32).sum::<i32>() != 0 {
            continue;
        }
        let mut winding = 0i32;
        let mut next = relevant().peekable();
        for (f, cell) in fine.iter_mut().enumerate() {
            let centre = f as f64 + 0.5;
            while let Some(h) = next.next_if(|h| h.t <= centre) {
                winding += h.winding as i32;
            }
            if winding != 0 {
                *cell |= bit;
            }
        }
    }
}

/// Adds the crossings of triangle `t` with the column's rays (`first` = fine index of the
/// column's first ray along u and v) to `rays`.
fn rasterize(
    model: &ScanModel,
    axis: usize,
    t: u32,
    first: [usize; 2],
    rays: &mut [Vec<Crossing>],
) {
    let k = model.grid.k;
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let c = &model.corners[t as usize];
    let snap = |p: DVec3| {
        [
            (p[u] * SUBPIXEL).round() as i64,
            (p[v] * SUBPIXEL).round() as i64,
        ]
    };
    let mut q = [snap(c[0]), snap(c[1]), snap(c[2])];
    let mut order = [0usize, 1, 2];
    let edge = |a: [i64; 2], b: [i64; 2], p: [i64; 2]| {
        (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
    };
    let area = edge(q[0], q[1], q[2]);
    if area == 0 {
        return; // seen edge-on from this axis; the other axes see it
    }
    // Counter-clockwise seen from +axis means the normal points along +axis: a ray going +axis
    // leaves the solid there.
    let faces_plus = area > 0;
    if !faces_plus {
        q.swap(1, 2);
        order.swap(1, 2);
    }
    let area = area.abs() as f64;
    // Top-left rule: a sample exactly on an edge belongs to the triangle for which the edge
    // runs downwards (or leftwards when horizontal); the neighbour across the edge runs it the
    // other way, so exactly one of them takes the sample.
    let bias = |a: [i64; 2], b: [i64; 2]| {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        if dy < 0 || (dy == 0 && dx < 0) { 0 } else { -1 }
    };
    let edges = [(1, 2), (2, 0), (0, 1)].map(|(a, b)| (q[a], q[b], bias(q[a], q[b])));

    let lo = |d: usize| q.iter().map(|p| p[d]).min().unwrap_or(0);
    let hi = |d: usize| q.iter().map(|p| p[d]).max().unwrap_or(0);
    let sample = |i: usize| i as i64 * SUBPIXEL as i64 + SUBPIXEL as i64 / 2;
    let to_ray = |x: i64| (x - SUBPIXEL as i64 / 2).div_euclid(SUBPIXEL as i64);
    let i0 = (to_ray(lo(0) + SUBPIXEL as i64 - 1)).max(first[0] as i64);
    let i1 = to_ray(hi(0)).min((first[0] + k) as i64 - 1);
    let j0 = (to_ray(lo(1) + SUBPIXEL as i64 - 1)).max(first[1] as i64);
    let j1 = to_ray(hi(1)).min((first[1] + k) as i64 - 1);

    let mesh = model.mesh;
    let triangle = &mesh.triangles[t as usize];
    let material = &mesh.materials[triangle.material as usize];
    let winding = if model.is_closed[t as usize] {
        if faces_plus { -1 } else { 1 }
    } else {
        0
    };
    let is_foliage = model.is_foliage[t as usize];
    let normal = (c[1] - c[0])
        .cross(c[2] - c[0])
        .normalize_or_zero()
        .as_vec3()
        .to_array();
    for j in j0.max(0)..=j1 {
        for i in i0.max(0)..=i1 {
            let p = [sample(i as usize), sample(j as usize)];
            let e = edges.map(|(a, b, bias)| edge(a, b, p) + bias);
            if e.iter().any(|&e| e < 0) {
                continue;
            }
            // Barycentric weights of the (possibly swapped) corners, back in triangle order.
            let w_sorted = [0, 1, 2].map(|n| (e[n] - edges[n].2) as f64 / area);
            let mut w = [0.0f64; 3];
            for n in 0..3 {
                w[order[n]] = w_sorted[n];
            }
            let depth = w[0] * c[0][axis] + w[1] * c[1][axis] + w[2] * c[2][axis];
            let wf = w.map(|x| x as f32);
            let color = mesh.base_color(triangle, wf);
            let ray = (i as usize - first[0]) + k * (j as usize - first[1]);
            if alpha_covers(material.alpha_mode, color.w, axis, [i, j], t) {
                rays[ray].push(Crossing {
                    t: depth,
                    triangle: t,
                    winding,
                    is_foliage,
                    rgb: [color.x, color.y, color.z],
                    normal,
                });
            }
        }
    }
}

/// Whether a crossing with alpha `alpha` counts: always for opaque materials, above the cutoff
/// for masked ones, and with probability alpha for blended ones (a hash of the ray and the
/// triangle, so the bake stays deterministic).
fn alpha_covers(mode: AlphaMode, alpha: f32, axis: usize, [i, j]: [i64; 2], t: u32) -> bool {
    match mode {
        AlphaMode::Opaque => true,
        AlphaMode::Mask { cutoff } => alpha >= cutoff,
        AlphaMode::Blend => {
            let id = (((axis as u64) << 40) | ((i as u64) << 20)) | j as u64;
            alpha as f64 > rng::unit(rng::hash3(rng::purpose::BAKE_BLEND, id, t as u64))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conditional_extinction_telescopes_to_the_column_miss_fraction() {
        // 64 rays; 10 first blocked in cell 1, 20 in cell 3; 34 cross. Last crossings elsewhere.
        let first = [0, 10, 0, 20, 0];
        let last = [0, 0, 5, 25, 0];
        let sigma = conditional_extinction(&first, &last, 34, 64, 0.5);
        let depth: f64 = sigma.iter().map(|s| s.unwrap() as f64 * 0.5).sum();
        assert!((depth - -(34.0f64 / 64.0).ln()).abs() < 1e-6, "{depth}");
    }

    #[test]
    fn cells_behind_an_opaque_cell_are_undetermined_from_that_side() {
        let sigma = conditional_extinction(&[64, 0, 0], &[0, 0, 64], 0, 64, 1.0);
        let max = (128.0f64).ln() as f32;
        assert_eq!(sigma, vec![Some(max), None, Some(max)]);
    }
}
