//! Solids: the model's thick closed parts, drawn as opaque surfaces instead of as a medium.
//!
//! Low-poly trees build a crown as one closed blob (KayKit, Kenney's birch). Baked into
//! density, a blob is a cloud whose edge trilinear reconstruction widens by up to half a cell;
//! the directional fit then thins the whole cloud until its silhouette is the mesh's (to
//! 0.12-0.35 of its extinction for the KayKit crowns), and the renderer draws a
//! half-transparent shell. A view ray gets a cell or two into it, and its samples there are
//! shadowed by the shell in front of them (the KayKit forests came out 12-20 % dark), or the
//! lit shells cover the shadowed gaps between crowns (Kenney's birch 9-15 % bright).
//!
//! A closed component thick enough for the grid to hold its shape is therefore kept out of
//! the density and stored as a solid: per cell the fraction of it inside the component (a box
//! filter of the inside), whose trilinear field crosses [`SOLID_LEVEL`] where a box-filtered
//! surface lies. The renderer draws that level set as an opaque surface, with the field's
//! gradient as its normal. Thin closed parts (branches, most trunks) stay in the density, as
//! do all open surfaces (leaf cards). A coarser level whose cells no longer hold the solids'
//! shape (the level set keeps too little of their volume) goes back to the density of the
//! whole model, as it and every coarser level were baked before solids.

use glam::DVec3;

use super::grid::Grid;
use super::scan::{AxisScan, INSIDE_ALL, INSIDE_WOOD, fine_bits};
use crate::import::Mesh;
use crate::volume::{DensityModel, Level};

/// How thick a closed component must be, in level-0 cells, to be drawn as a solid: its
/// volume over its area, times 3, which is a sphere's radius, two thirds of a long
/// cylinder's and one and a half times a plate's thickness. A plate 1.33 cells thick always
/// has a cell at least half inside across it, wherever it lies in the grid, so its level set
/// holds; a thinner one would come out in holes.
pub const THICK_CELLS: f64 = 2.0;

/// The most fine cells a bake splits solids off in: their inside is the occupancy model's vote
/// over the three axes' fine cells, which holds three bytes a fine cell (100 MB here; a
/// `--fine 4096` grid would need 200 GB). Finer bakes keep their thick parts as density, as
/// bakes did before solids. The default `--fine 256` stays within it.
pub const MAX_FINE_CELLS: usize = 1 << 25;

/// The least share of a level's solid volume (the sum of its inside fractions) that the level
/// set must keep for the level to draw solids, and the most it may add: outside these, the
/// cells are too coarse for the solids' shape.
const KEPT: (f64, f64) = (0.75, 1.33);

/// Sub-points per cell edge at which [`holds`] samples the level set.
const SUBSAMPLES: usize = 4;

/// Which triangles bound a thick closed component (`components` from
/// `classify::closed_components`), for a grid of `cell` metres.
pub fn thick_triangles(mesh: &Mesh, components: &[Option<u32>], cell: f64) -> Vec<bool> {
    let n = components
        .iter()
        .flatten()
        .map(|&c| c as usize + 1)
        .max()
        .unwrap_or(0);
    let (mut volume, mut area) = (vec![0.0f64; n], vec![0.0f64; n]);
    for (t, c) in mesh.triangles.iter().zip(components) {
        let Some(c) = c else { continue };
        let [a, b, d] = t.vertices.map(|v| mesh.positions[v as usize].as_dvec3());
        // Divergence theorem: the signed volume of the tetrahedra from the origin.
        volume[*c as usize] += a.dot(b.cross(d)) / 6.0;
        area[*c as usize] += (b - a).cross(d - a).length() / 2.0;
    }
    let thick: Vec<bool> = (0..n)
        .map(|c| area[c] > 0.0 && 3.0 * volume[c].abs() / area[c] >= THICK_CELLS * cell)
        .collect();
    if std::env::var("TEXEL_DEBUG_SOLID").is_ok() {
        for c in 0..n {
            eprintln!(
                "component {c}: volume {:.3} area {:.3} thickness {:.3} cells",
                volume[c],
                area[c],
                3.0 * volume[c].abs() / area[c] / cell
            );
        }
        let open = components.iter().filter(|c| c.is_none()).count();
        eprintln!("{open} open triangles");
    }
    components
        .iter()
        .map(|c| c.is_some_and(|c| thick[c as usize]))
        .collect()
}

/// What the thick parts become: per texture cell and part `[wood, foliage]`, the fraction of
/// its fine cells whose centre is inside them (`solid`), and the fraction inside them that the
/// level set of those fractions leaves out (`lost`: a crown's rim thinner than a cell), which
/// the density must carry.
pub struct Split {
    pub solid: [Vec<f32>; 2],
    pub lost: [Vec<f32>; 2],
}

/// Splits the thick parts (`scans` made with occupancy, of the thick parts alone): inside is the
/// two-of-three vote of the occupancy model, without its surface cells.
pub fn split(grid: &Grid, scans: &[AxisScan]) -> Split {
    let k = grid.k;
    // Per fine cell: 0 outside, 1 inside wood, 2 inside foliage.
    let part = |f: [usize; 3]| -> u8 {
        let bits = fine_bits(grid, scans, f);
        let votes = |m: u8| bits.iter().filter(|b| *b & m != 0).count();
        if votes(INSIDE_WOOD) >= 2 {
            1
        } else if votes(INSIDE_ALL) >= 2 {
            2
        } else {
            0
        }
    };
    let n = grid.dims.iter().product::<usize>();
    let cell_fine = |c: [usize; 3]| {
        (c[2] * k..(c[2] + 1) * k).flat_map(move |fz| {
            (c[1] * k..(c[1] + 1) * k)
                .flat_map(move |fy| (c[0] * k..(c[0] + 1) * k).map(move |fx| [fx, fy, fz]))
        })
    };
    let cells = || {
        (0..grid.dims[2]).flat_map(move |z| {
            (0..grid.dims[1]).flat_map(move |y| (0..grid.dims[0]).map(move |x| [x, y, z]))
        })
    };
    let per = (k * k * k) as f32;
    let mut level = Level::empty(grid.dims, grid.cell);
    level.solid = [vec![0.0f32; n], vec![0.0f32; n]];
    for (i, c) in cells().enumerate() {
        for f in cell_fine(c) {
            match part(f) {
                1 => level.solid[0][i] += 1.0,
                2 => level.solid[1][i] += 1.0,
                _ => {}
            }
        }
        level.solid[0][i] /= per;
        level.solid[1][i] /= per;
    }
    let mut lost = [vec![0.0f32; n], vec![0.0f32; n]];
    for (i, c) in cells().enumerate() {
        if level.solid[0][i] + level.solid[1][i] == 0.0 {
            continue;
        }
        for f in cell_fine(c) {
            let p = part(f);
            if p == 0 {
                continue;
            }
            let at = glam::Vec3::new(f[0] as f32, f[1] as f32, f[2] as f32) + 0.5;
            if !level.in_solid(at / k as f32, 1.0) {
                lost[p as usize - 1][i] += 1.0 / per;
            }
        }
    }
    Split {
        solid: level.solid,
        lost,
    }
}

/// The density of a cell of which `fraction` is solid, for `model`: the occupancy model's
/// fraction, or the extinction that lets through what the rest of the cell does (at most the
/// transmittance model's opaque value, `1 / 2k²`), over a cell of `cell` metres.
pub fn lost_density(fraction: f32, model: DensityModel, k: usize, cell: f64) -> f32 {
    match model {
        DensityModel::Occupancy => fraction,
        DensityModel::Transmittance => {
            let through = (1.0 - f64::from(fraction)).max(1.0 / (2 * k * k) as f64);
            (-through.ln() / cell) as f32
        }
    }
}

/// Whether `level`'s cells hold its solids' shape: the volume inside the level set (sampled
/// at [`SUBSAMPLES`]^3 points a cell, full foliage) against the solids' own volume.
pub fn holds(level: &Level) -> bool {
    if !level.has_solid() {
        return false;
    }
    let own: f64 = level.solid.iter().flatten().map(|&s| f64::from(s)).sum();
    if own <= 0.0 {
        return false;
    }
    let mut kept = 0usize;
    let m = SUBSAMPLES;
    for z in 0..level.dims[2] * m {
        for y in 0..level.dims[1] * m {
            for x in 0..level.dims[0] * m {
                let c = (DVec3::new(x as f64, y as f64, z as f64) + 0.5) / m as f64;
                kept += usize::from(level.in_solid(c.as_vec3(), 1.0));
            }
        }
    }
    let kept = kept as f64 / (m * m * m) as f64;
    let share = kept / own;
    (KEPT.0..=KEPT.1).contains(&share)
}

/// The levels a bake keeps: `with_solids[n]` while every level up to `n` holds its solids
/// ([`holds`]), then `without[n]`, the model baked as density alone.
pub fn choose(without: Vec<Level>, with_solids: Vec<Level>) -> Vec<Level> {
    let mut solid = true;
    without
        .into_iter()
        .zip(with_solids)
        .map(|(plain, solids)| {
            solid = solid && holds(&solids);
            if solid { solids } else { plain }
        })
        .collect()
}

/// The field value [`Level::in_solid`] compares with [`SOLID_LEVEL`], for tests.
#[cfg(test)]
fn field(level: &Level, c: glam::Vec3) -> f32 {
    let [w, f] = level.solid_parts_at(c);
    w + f
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::SOLID_LEVEL;
    use glam::Vec3;

    /// A ball of radius `r` cells, box-filtered into a grid of `n` cells.
    fn ball(n: usize, r: f64) -> Level {
        let mut l = Level::empty([n; 3], 1.0);
        l.solid = [vec![0.0; n * n * n], vec![0.0; n * n * n]];
        let centre = DVec3::splat(n as f64 / 2.0 + 0.13);
        let m = 8;
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let mut inside = 0;
                    for s in 0..m * m * m {
                        let p = DVec3::new(
                            (x * m + s % m) as f64,
                            (y * m + s / m % m) as f64,
                            (z * m + s / (m * m)) as f64,
                        ) / m as f64
                            + 0.5 / m as f64;
                        inside += usize::from(p.distance(centre) < r);
                    }
                    let i = l.index(x, y, z);
                    l.solid[1][i] = inside as f32 / (m * m * m) as f32;
                }
            }
        }
        l
    }

    /// The level set of a box-filtered ball lies on the ball, within 0.15 of a cell (it
    /// cuts a little inside where the surface curves through a cell), and its normal points
    /// away from the centre.
    #[test]
    fn a_balls_level_set_is_the_ball() {
        let l = ball(16, 5.0);
        let centre = Vec3::splat(8.13);
        for k in 0..200 {
            let a = k as f32 * 2.399;
            let z = 1.0 - 2.0 * (k as f32 + 0.5) / 200.0;
            let d = Vec3::new(
                a.cos() * (1.0 - z * z).sqrt(),
                z,
                a.sin() * (1.0 - z * z).sqrt(),
            );
            // Where along d from the centre the field crosses the level.
            let (mut lo, mut hi) = (0.0f32, 8.0f32);
            for _ in 0..40 {
                let mid = 0.5 * (lo + hi);
                if field(&l, centre + d * mid) >= SOLID_LEVEL {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            assert!((lo - 5.0).abs() < 0.15, "{d}: surface at {lo}");
            let n = l.solid_normal(centre + d * lo, 1.0).unwrap();
            assert!(n.dot(d) > 0.98, "{d}: normal {n}");
        }
        assert!(holds(&l));
    }

    /// A ball one cell across keeps too little of itself: the level falls back to density.
    #[test]
    fn a_ball_too_small_for_its_cells_is_not_held() {
        assert!(!holds(&ball(8, 0.6)));
        assert!(holds(&ball(8, 2.5)));
    }

    /// A closed cube of side `a` is `a / 2` thick: a solid from cells of `a / 4` down.
    #[test]
    fn thickness_is_three_volumes_over_the_area() {
        use crate::import::Material;
        let corners: Vec<Vec3> = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, (i >> 1 & 1) as f32, (i >> 2) as f32) * 4.0)
            .collect();
        let faces = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let tris: Vec<[u32; 3]> = faces
            .iter()
            .flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]])
            .collect();
        let cube = Mesh::plain(corners, &tris, Material::default());
        let components = super::super::classify::closed_components(&cube);
        assert!(components.iter().all(Option::is_some));
        assert!(thick_triangles(&cube, &components, 0.95).iter().all(|&t| t));
        assert!(!thick_triangles(&cube, &components, 1.05).iter().any(|&t| t));
    }
}
