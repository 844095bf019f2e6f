//! A baked 3D texture in memory: a mip chain of grids of extinction, density gradient and
//! albedo, split into wood and foliage. This is what `.texel` files hold (see
//! `formats/texel.md`) and what the renderer samples.
//!
//! Values are cell averages located at cell centres; between centres they are interpolated
//! trilinearly, within half a cell of the grid's faces they are held constant (clamp to edge),
//! and outside the grid the texture is empty. With that convention the optical depth along any
//! axis-aligned line through cell centres is exactly the sum of `sigma x cell` over the cells.

use glam::{DVec3, Vec3};
use serde::Serialize;

use crate::provenance::SourceFile;

/// How the density channels relate to extinction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, bincode::Encode, bincode::Decode)]
pub enum DensityModel {
    /// The paper's: density is the solid occupancy of the cell (0..1), extinction is gamma x it.
    Occupancy,
    /// Density is extinction (1/m) calibrated so axis-aligned optical depths match the mesh.
    Transmittance,
}

impl DensityModel {
    pub fn name(self) -> &'static str {
        match self {
            DensityModel::Occupancy => "occupancy",
            DensityModel::Transmittance => "transmittance",
        }
    }
}

/// Angles (degrees) between the directions to the eye and to the sun at which a level stores
/// its self-shadowing factors (`formats/texel.md`, *Self-shadowing*).
pub const SELF_SHADOW_ANGLES: [f32; 6] = [0.0, 15.0, 30.0, 60.0, 90.0, 180.0];

/// Heights of the sun (degrees above the model's horizontal plane) at which a level stores
/// its self-shadowing factors since texel 1.5 (`formats/texel.md`, *Self-shadowing*).
pub const SUN_HEIGHTS: [f32; 4] = [0.0, 30.0, 60.0, 90.0];

/// Heights of the eye (degrees above the model's horizontal plane, seen from the point) at
/// which a level stores its self-shadowing factors since texel 1.6: the bake's view elevations.
pub const EYE_HEIGHTS: [f32; 3] = [10.0, 35.0, 60.0];

/// Turns of the sun about the direction to the eye (degrees: 0 where the sun stands above the
/// eye's line of sight, 90 beside it, 180 below it) at which a level stores its
/// self-shadowing factors since texel 1.6.
pub const SUN_TURNS: [f32; 3] = [0.0, 90.0, 180.0];

/// A level's self-shadowing rows by the eye's height and the sun's turn about the eye
/// (texel 1.6): `[eye height][sun turn]`, each row at [`SELF_SHADOW_ANGLES`].
pub type ByView = [[[f32; 6]; SUN_TURNS.len()]; EYE_HEIGHTS.len()];

/// Where the sun stands as seen from a point the eye sees: what a level's self-shadowing
/// factor depends on. A tree turned about +Y sees the same, so model and world space agree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunFromEye {
    /// Degrees between the directions to the eye and to the sun.
    pub angle: f32,
    /// Degrees of the sun above the horizontal plane.
    pub sun_height: f32,
    /// Degrees of the eye above the horizontal plane.
    pub eye_height: f32,
    /// Degrees the sun is turned about the direction to the eye, from up (see [`SUN_TURNS`]);
    /// 90 where that is undefined (the eye straight above or below, or the sun behind it).
    pub turn: f32,
}

impl SunFromEye {
    /// From the unit directions from the point to the eye and to the sun.
    pub fn new(to_eye: Vec3, to_sun: Vec3) -> SunFromEye {
        let degrees = |cos: f32| cos.clamp(-1.0, 1.0).acos().to_degrees();
        // Parts shorter than 1e-4 (a hundredth of a degree off the line of sight) are
        // rounding, not a direction.
        let direction = |v: Vec3| (v.length_squared() > 1e-8).then(|| v.normalize());
        let up = direction(Vec3::Y - to_eye * to_eye.y);
        let offset = direction(to_sun - to_eye * to_eye.dot(to_sun));
        SunFromEye {
            angle: degrees(to_eye.dot(to_sun)),
            sun_height: 90.0 - degrees(to_sun.y),
            eye_height: 90.0 - degrees(to_eye.y),
            turn: match (up, offset) {
                (Some(up), Some(offset)) => degrees(up.dot(offset)),
                _ => 90.0,
            },
        }
    }
}

/// A level's self-shadowing factors: the multiplier on the tree's own extinction along a
/// foliage sample's shadow ray, per angle of [`SELF_SHADOW_ANGLES`] between the directions to
/// the eye and to the sun, and by where the sun and the eye stand.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelfShadow {
    /// Fitted to suns of every height alike: the only row of texel 1.2 to 1.4, which readers
    /// of those versions use.
    pub pooled: [f32; 6],
    /// One row per height of [`SUN_HEIGHTS`] (texel 1.5): how much a tree shadows what the
    /// eye sees of it depends on how high the sun stands, not only on the angle. What 1.5
    /// readers use.
    pub by_height: [[f32; 6]; SUN_HEIGHTS.len()],
    /// Rows by the eye's height and the sun's turn about the eye (texel 1.6): at one angle the
    /// factor depends on whether the sun stands above the eye's line of sight, beside it or
    /// below it (the fixture conifer, level 0, the eye 25 degrees high, the sun 20 from it:
    /// 1.12, 0.56 and 0.78), which a row by the sun's height pools over the views. `None` in
    /// files before 1.6, whose renderer reads `by_height`.
    pub by_view: Option<ByView>,
}

impl SelfShadow {
    /// Independent media: every factor 1.
    pub const NONE: SelfShadow = SelfShadow::uniform([1.0; 6]);

    /// One row for suns of every height (files before texel 1.5).
    pub const fn uniform(row: [f32; 6]) -> SelfShadow {
        SelfShadow {
            pooled: row,
            by_height: [row; SUN_HEIGHTS.len()],
            by_view: None,
        }
    }

    /// The factor where the sun stands at `s`: linear in the angle between the stored ones,
    /// and in the eye's height and the sun's turn (1.6), else in the sun's height (1.5), each
    /// clamped to the stored range.
    pub fn at(&self, s: &SunFromEye) -> f32 {
        let (i, u) = bracket(&SELF_SHADOW_ANGLES, s.angle);
        let row = |r: &[f32; 6]| r[i] * (1.0 - u) + r[i + 1] * u;
        match &self.by_view {
            Some(rows) => {
                let (eye, turn) = (hat(&EYE_HEIGHTS, s.eye_height), hat(&SUN_TURNS, s.turn));
                let mut k = 0.0;
                for (we, rows) in eye.iter().zip(rows) {
                    for (wt, r) in turn.iter().zip(rows) {
                        if we * wt > 0.0 {
                            k += we * wt * row(r);
                        }
                    }
                }
                k
            }
            None => hat(&SUN_HEIGHTS, s.sun_height)
                .iter()
                .zip(&self.by_height)
                .filter(|(w, _)| **w > 0.0)
                .map(|(w, r)| w * row(r))
                .sum(),
        }
    }
}

/// Where `x` falls among the increasing `nodes`: the index of the interval's lower end and
/// the fraction of the way along it, clamped to the ends.
fn bracket(nodes: &[f32], x: f32) -> (usize, f32) {
    let i = nodes[1..]
        .iter()
        .position(|&n| x <= n)
        .unwrap_or(nodes.len() - 2);
    let u = ((x - nodes[i]) / (nodes[i + 1] - nodes[i])).clamp(0.0, 1.0);
    (i, if u.is_nan() { 0.0 } else { u })
}

/// The weight of each of the increasing `nodes` in linear interpolation at `x` (clamped to
/// the ends): at most two are not 0, and they sum to 1. The renderer reads a table with these
/// weights, and the bake counts a measurement in each node's fit with them.
pub fn hat<const N: usize>(nodes: &[f32; N], x: f32) -> [f32; N] {
    let (i, u) = bracket(nodes, x);
    let mut w = [0.0; N];
    w[i] = 1.0 - u;
    w[i + 1] += u;
    w
}

/// The leaf-normal moment of leaves facing every way alike: `E[n n^T] = I / 3`.
pub const ISOTROPIC_LEAVES: [f32; 6] = [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0, 0.0, 0.0, 0.0];

/// How much of each part of a level faces a view: the factors on the wood's and the foliage's
/// extinction along a view ray (formats/texel.md, *Each part along the view*). A level's
/// directional form turns the whole tree's extinction with the direction, both parts alike;
/// but each part blocks a view by its surfaces' area projected on it, and the parts' surfaces
/// face different ways (a broadleaf's leaf cards lie flatter than its branches stand). With
/// both parts turned alike, the fixture broadleaf's texture showed 0.66 of the wood its mesh
/// shows from 10 degrees up and 1.16 from 51 degrees up, its leaves 1.17 and 0.96: from the
/// side its leaves hid too much of the crown's inside (README, *The wood a crown shows, by the
/// eye's height*). So each part's extinction along a view `w` is multiplied by `g_p(w) / g(w)`:
/// `g_p(w) = sqrt(max(3 w^T M_p w, 1/16))`, the root mean square of `|n . w|` over the part's
/// normal distribution `M_p` (its cells' `E[n n^T]` averaged over the level, weighted by the
/// part's density) relative to an isotropic part's, and `g(w)` the two parts' mean weighted by
/// their densities summed over the level, so that the level's extinction keeps the total its
/// directional form was fitted to. Rays towards the sun keep both parts as they are: the
/// self-shadowing factors were fitted to them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PartFacing {
    /// Each part's normal distribution `[xx, yy, zz, xy, xz, yz]`, averaged over the level.
    normals: [[f32; 6]; 2],
    /// Each part's density summed over the level.
    totals: [f32; 2],
}

impl PartFacing {
    /// Both parts facing every way alike: the factors are 1.
    pub const ALIKE: PartFacing = PartFacing {
        normals: [ISOTROPIC_LEAVES; 2],
        totals: [1.0; 2],
    };

    /// The level's parts' mean normal distributions ([`Level::wood_normals`],
    /// [`Level::leaves`]); [`PartFacing::ALIKE`] where the level has no wood normals (files
    /// before texel 1.4).
    pub fn of(level: &Level) -> PartFacing {
        if level.wood_normals.is_empty() {
            return PartFacing::ALIKE;
        }
        let mut sums = [[0.0f64; 6]; 2];
        let mut totals = [0.0f64; 2];
        for (p, normals) in [&level.wood_normals, &level.leaves].into_iter().enumerate() {
            for (&d, n) in level.density[p].iter().zip(normals) {
                if d > 0.0 {
                    let d = f64::from(d);
                    for k in 0..6 {
                        sums[p][k] += d * f64::from(n[k]);
                    }
                    totals[p] += d;
                }
            }
        }
        if totals.iter().all(|&t| t <= 0.0) {
            return PartFacing::ALIKE;
        }
        PartFacing {
            normals: std::array::from_fn(|p| {
                if totals[p] > 0.0 {
                    sums[p].map(|v| (v / totals[p]) as f32)
                } else {
                    ISOTROPIC_LEAVES
                }
            }),
            totals: totals.map(|t| t as f32),
        }
    }

    /// The factors `[wood, foliage]` on each part's extinction along direction `d` (model
    /// space, any length; 1 for a zero `d`).
    pub fn along(&self, d: Vec3) -> [f32; 2] {
        let Some(w) = d.try_normalize() else {
            return [1.0; 2];
        };
        let g = self
            .normals
            .map(|m| (3.0 * quadratic_form(m, w)).max(1.0 / 16.0).sqrt());
        let [tw, tf] = self.totals;
        let mean = (tw * g[0] + tf * g[1]) / (tw + tf);
        let factors = g.map(|g| g / mean);
        if factors.iter().all(|f| f.is_finite()) {
            factors
        } else {
            [1.0; 2]
        }
    }
}

/// `w^T M w` for the symmetric matrix `M = [xx, yy, zz, xy, xz, yz]` (a directional form's
/// quadratic part, a normal distribution's mean squared `n . w`).
#[inline]
fn quadratic_form([xx, yy, zz, xy, xz, yz]: [f32; 6], w: Vec3) -> f32 {
    let w2 = w * w;
    xx * w2.x + yy * w2.y + zz * w2.z + 2.0 * (xy * w.x * w.y + xz * w.x * w.z + yz * w.y * w.z)
}

/// The second moment `n n^T` of one unit normal, `[xx, yy, zz, xy, xz, yz]`: what a surface
/// adds to its cell's normal distribution (`Level::leaves`, `Level::wood_normals`).
pub fn normal_moment(n: glam::Vec3) -> [f32; 6] {
    [
        n.x * n.x,
        n.y * n.y,
        n.z * n.z,
        n.x * n.y,
        n.x * n.z,
        n.y * n.z,
    ]
}

/// `m` held to what a second moment of unit vectors can be (diagonal in [0, 1], the rest in
/// [-1, 1]): sums in floating point may overshoot by a rounding.
pub fn unit_moment(m: [f32; 6]) -> [f32; 6] {
    std::array::from_fn(|k| {
        if k < 3 {
            m[k].clamp(0.0, 1.0)
        } else {
            m[k].clamp(-1.0, 1.0)
        }
    })
}

/// The directional form of an isotropic level: `q(w) = 1`.
pub const ISOTROPIC: [f32; 7] = [1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0];

/// The least `q(w)` a directional form is taken to reach (a factor of 1/64): below it, `q` is
/// clamped, so that no form, however fitted or damaged, makes extinction vanish or negative.
pub const DIRECTIONAL_FLOOR: f32 = 1.0 / 4096.0;

/// One level of the mip chain. Arrays are indexed `x + nx * (y + ny * z)`; the per-part pairs
/// are `[wood, foliage]`: foliage follows the season, wood does not.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    pub dims: [usize; 3],
    /// Edge of a cell, metres.
    pub cell: f64,
    /// Density per part (see [`DensityModel`]).
    pub density: [Vec<f32>; 2],
    /// Gradient of each part's density (density units per metre), by the 3D Sobel operator.
    pub gradient: [Vec<[f32; 3]>; 2],
    /// Linear albedo of each part's surfaces; filled in from neighbours where the part is absent.
    pub albedo: [Vec<[f32; 3]>; 2],
    /// The foliage's leaf-normal distribution per cell: the area-weighted second moment
    /// `E[n n^T]` of its surface normals, `[xx, yy, zz, xy, xz, yz]` (trace 1), which shades
    /// the foliage as a cloud of leaves (see `render::shading`); [`ISOTROPIC_LEAVES`] where no
    /// leaf was seen, and in files before texel 1.2.
    pub leaves: Vec<[f32; 6]>,
    /// The wood's normal distribution per cell, as [`Level::leaves`] is the foliage's (a thin
    /// branch's is its cylinder's normals, `(I - a a^T) / 2` for axis `a`), which shades the
    /// wood where its density gradient says little (`render::integrate`); empty where the
    /// level has none (files before texel 1.4), and the wood is then shaded on its gradient.
    pub wood_normals: Vec<[f32; 6]>,
    /// Directional extinction `[S_xx, S_yy, S_zz, S_xy, S_xz, S_yz, c]`: along a unit
    /// direction `w` extinction is the stored one times `sqrt(q(w))`, `q(w) = w^T S w + c (w_x^4
    /// + w_y^4 + w_z^4)` (see `bake::calibrate`; [`ISOTROPIC`] in files before texel 1.2).
    pub directional: [f32; 7],
    /// Self-shadowing (see `bake::seen`; [`SelfShadow::NONE`] in files before texel 1.2, one
    /// row for every sun height before 1.5).
    pub self_shadow: SelfShadow,
    /// The weight on the wood's extinction in choosing which part of a sample scatters: the
    /// wood shows as much as in the mesh, not wherever a coarse cell mixes it with foliage
    /// (see `bake::seen`; 1 in files before texel 1.2). Where the level has
    /// [`Level::wood_shown`] (texel 1.7), that replaces it.
    pub wood_weight: f32,
    /// The wood's density as it counts in choosing which part of a sample scatters, per cell:
    /// the density times the weight that makes the cell show its wood first as often as the
    /// mesh does within it (`bake::seen::wood_shown`). Empty where the level has none (files
    /// before texel 1.7, and textures of one part), and [`Level::wood_weight`] then weighs the
    /// wood's density.
    pub wood_shown: Vec<f32>,
    /// The solids per part: the fraction of each cell inside the model's thick closed parts
    /// (`bake::solid`), drawn as opaque surfaces where the trilinear field of
    /// `solid_wood + f solid_foliage` reaches [`SOLID_LEVEL`]. Both empty where the level has
    /// none (every level of files before texel 1.3).
    pub solid: [Vec<f32>; 2],
}

/// The value of the solids' trilinear field at their surface: a box-filtered half-space
/// crosses a half exactly at its plane, so the level set of the cells' inside fractions
/// puts a solid's surface where the mesh has it, to well within a cell.
pub const SOLID_LEVEL: f32 = 0.5;

/// The extinction (1/m) queries that sum optical depth give the inside of a solid: opaque over
/// any step (a nanometre's depth is 1e9), finite so that sums and products stay numbers.
pub const SOLID_EXTINCTION: f32 = 1e18;

/// Whether `c` (cell units from the grid origin) lies in a grid of `dims` cells, faces
/// included: where [`Level::trilinear`] reads, and where [`Stencils::holds`] looks.
#[inline(always)]
fn inside(c: Vec3, dims: [usize; 3]) -> bool {
    c.is_finite()
        && c.cmpge(Vec3::ZERO).all()
        && c.x <= dims[0] as f32
        && c.y <= dims[1] as f32
        && c.z <= dims[2] as f32
}

/// A point's trilinear stencil along each axis of a grid ([`clamped_axis`]), where the point
/// lies in the grid: worked out once, it serves both the stencil's bit ([`Stencils::holds_at`])
/// and the cells' reads ([`Level::fetch_at`]).
#[derive(Clone, Copy, Debug)]
pub struct Axes {
    along: [(usize, usize, f32); 3],
    /// The grid's dimensions they were worked out for: only a grid of these reads them (the
    /// renderer takes them from the level it reads, so no file can make them differ).
    dims: [usize; 3],
}

impl Axes {
    /// The axes at `c` (cell units from the grid origin) in a grid of `dims` cells; `None`
    /// outside it, where nothing is read.
    #[inline(always)]
    pub fn at(c: Vec3, dims: [usize; 3]) -> Option<Axes> {
        inside(c, dims).then(|| Axes {
            along: [
                clamped_axis(c.x, dims[0]),
                clamped_axis(c.y, dims[1]),
                clamped_axis(c.z, dims[2]),
            ],
            dims,
        })
    }
}

/// Linear interpolation's two cells and weight along one axis of `n` cells (centres at
/// i + 0.5) at `v`, clamped to the edge: `(i0, i1, weight of i1)`.
#[inline(always)]
pub fn clamped_axis(v: f32, n: usize) -> (usize, usize, f32) {
    let x = (v - 0.5).clamp(0.0, (n - 1) as f32);
    let i = (x as usize).min(n - 1);
    (i, (i + 1).min(n - 1), x - i as f32)
}

/// Linear interpolation's two cells and weights along one axis of `n` cells (centres at
/// i + 0.5) at `v`, the field 0 beyond the cells rather than clamped to the edge: a cell
/// outside comes back as index 0 with weight 0. The solids are read so: a model touches its
/// grid's faces, and a solid clamped to the edge would reach out to the face wherever its edge
/// cell is half inside.
#[inline]
pub fn padded_axis(v: f32, n: usize) -> [(usize, f32); 2] {
    let x = v - 0.5;
    let i = x.floor();
    let f = x - i;
    let at = |j: f32, w: f32| {
        if j >= 0.0 && j < n as f32 {
            (j as usize, w)
        } else {
            (0, 0.0)
        }
    };
    [at(i, 1.0 - f), at(i + 1.0, f)]
}

impl Level {
    pub fn empty(dims: [usize; 3], cell: f64) -> Level {
        let n = dims.iter().product();
        Level {
            dims,
            cell,
            density: [vec![0.0; n], vec![0.0; n]],
            gradient: [vec![[0.0; 3]; n], vec![[0.0; 3]; n]],
            albedo: [vec![[0.0; 3]; n], vec![[0.0; 3]; n]],
            leaves: vec![ISOTROPIC_LEAVES; n],
            wood_normals: Vec::new(),
            directional: ISOTROPIC,
            self_shadow: SelfShadow::NONE,
            wood_weight: 1.0,
            wood_shown: Vec::new(),
            solid: [Vec::new(), Vec::new()],
        }
    }

    /// Whether this level draws any solid.
    #[inline]
    pub fn has_solid(&self) -> bool {
        !self.solid[0].is_empty()
    }

    /// Whether cell `i` holds anything a query reads: density of either part, or solid.
    #[inline]
    pub fn holds_cell(&self, i: usize) -> bool {
        self.density[0][i] != 0.0
            || self.density[1][i] != 0.0
            || (self.has_solid() && (self.solid[0][i] != 0.0 || self.solid[1][i] != 0.0))
    }

    /// The solids' field `[wood, foliage]` at `c` (cell units from the grid origin), read with
    /// empty cells around the grid ([`padded_axis`]); zeros outside the grid (and at a
    /// non-finite point) and where the level has no solid.
    #[inline]
    pub fn solid_parts_at(&self, c: Vec3) -> [f32; 2] {
        if !self.has_solid() {
            return [0.0; 2];
        }
        if !inside(c, self.dims) {
            return [0.0; 2];
        }
        let [x, y, z] = [0, 1, 2].map(|a| padded_axis(c[a], self.dims[a]));
        let mut out = [0.0f32; 2];
        for (iz, wz) in z {
            for (iy, wy) in y {
                for (ix, wx) in x {
                    let w = wx * wy * wz;
                    if w != 0.0 {
                        let i = self.index(ix, iy, iz);
                        out[0] += self.solid[0][i] * w;
                        out[1] += self.solid[1][i] * w;
                    }
                }
            }
        }
        out
    }

    /// Whether `c` lies inside the solids with leaf fraction `foliage` (the foliage's solids
    /// scale with it as its density does).
    #[inline]
    pub fn in_solid(&self, c: Vec3, foliage: f32) -> bool {
        if !self.has_solid() {
            return false;
        }
        let [w, f] = self.solid_parts_at(c);
        w + foliage * f >= SOLID_LEVEL
    }

    /// Part `part`'s albedo at `c` (cell units from the grid origin), interpolated.
    pub fn albedo_at(&self, part: usize, c: Vec3) -> Vec3 {
        let Some((idx, w)) = self.trilinear(c) else {
            return Vec3::ZERO;
        };
        (0..8)
            .map(|k| Vec3::from(self.albedo[part][idx[k]]) * w[k])
            .sum()
    }

    /// The outward normal of the solids' surface near `c` (model space axes): the trilinear
    /// interpolation of the 3D Sobel gradients of their field at the eight cells around `c`
    /// (as the density's normals are made), so that shading is continuous across cells;
    /// `None` where it is flat.
    pub fn solid_normal(&self, c: Vec3, foliage: f32) -> Option<Vec3> {
        let (idx, w) = self.trilinear(c)?;
        let [nx, ny, _] = self.dims;
        let mut g = Vec3::ZERO;
        for k in 0..8 {
            let i = idx[k];
            let at = [i % nx, i / nx % ny, i / (nx * ny)].map(|v| v as isize);
            g += self.solid_sobel(at, foliage) * w[k];
        }
        (-g).try_normalize()
    }

    /// The Sobel gradient (unscaled) of the solids' field at cell `at`, the field 0 outside
    /// the grid.
    fn solid_sobel(&self, at: [isize; 3], foliage: f32) -> Vec3 {
        let field = |d: [isize; 3]| {
            let p: [isize; 3] = std::array::from_fn(|a| at[a] + d[a]);
            if (0..3).any(|a| p[a] < 0 || p[a] >= self.dims[a] as isize) {
                return 0.0;
            }
            let i = self.index(p[0] as usize, p[1] as usize, p[2] as usize);
            self.solid[0][i] + foliage * self.solid[1][i]
        };
        let mut g = Vec3::ZERO;
        for a in 0..3 {
            let (u, v) = ((a + 1) % 3, (a + 2) % 3);
            for du in -1isize..=1 {
                for dv in -1isize..=1 {
                    let weight = ((2 - du.abs()) * (2 - dv.abs())) as f32;
                    let mut d = [0isize; 3];
                    d[u] = du;
                    d[v] = dv;
                    d[a] = 1;
                    let up = field(d);
                    d[a] = -1;
                    g[a] += weight * (up - field(d));
                }
            }
        }
        g
    }

    /// The factor extinction takes along direction `d` (model space, any non-zero length):
    /// `sqrt(max(q(w), DIRECTIONAL_FLOOR))` for `w = d / |d|`; 1 for a zero `d`.
    #[inline]
    pub fn directional_factor(&self, d: Vec3) -> f32 {
        let [xx, yy, zz, xy, xz, yz, c] = self.directional;
        let Some(w) = d.try_normalize() else {
            return 1.0;
        };
        let w2 = w * w;
        let q = quadratic_form([xx, yy, zz, xy, xz, yz], w)
            + c * (w2.x * w2.x + w2.y * w2.y + w2.z * w2.z);
        q.max(DIRECTIONAL_FLOOR).sqrt()
    }

    pub fn cell_count(&self) -> usize {
        self.dims.iter().product()
    }

    pub fn index(&self, x: usize, y: usize, z: usize) -> usize {
        x + self.dims[0] * (y + self.dims[1] * z)
    }

    /// The eight cells around `c` (cell units from the grid origin, centres at i + 0.5) and
    /// their trilinear weights, clamped to the edge inside the grid; `None` outside it.
    #[inline(always)]
    pub fn trilinear(&self, c: Vec3) -> Option<([usize; 8], [f32; 8])> {
        Some(self.stencil(&Axes::at(c, self.dims)?))
    }

    /// [`Level::trilinear`] from its axes, worked out once for a query that also looks at
    /// [`Stencils::holds_at`] first.
    #[inline(always)]
    fn stencil(&self, axes: &Axes) -> ([usize; 8], [f32; 8]) {
        let d = self.dims;
        debug_assert_eq!(axes.dims, d, "axes worked out for another grid");
        let [(x0, x1, fx), (y0, y1, fy), (z0, z1, fz)] = axes.along;
        let (sx, sxy) = (d[0], d[0] * d[1]);
        let idx = [
            x0 + sx * y0 + sxy * z0,
            x1 + sx * y0 + sxy * z0,
            x0 + sx * y1 + sxy * z0,
            x1 + sx * y1 + sxy * z0,
            x0 + sx * y0 + sxy * z1,
            x1 + sx * y0 + sxy * z1,
            x0 + sx * y1 + sxy * z1,
            x1 + sx * y1 + sxy * z1,
        ];
        let (gx, gy, gz) = (1.0 - fx, 1.0 - fy, 1.0 - fz);
        let w = [
            gx * gy * gz,
            fx * gy * gz,
            gx * fy * gz,
            fx * fy * gz,
            gx * gy * fz,
            fx * gy * fz,
            gx * fy * fz,
            fx * fy * fz,
        ];
        (idx, w)
    }

    /// Trilinear interpolation of a per-cell field at `p` (cell units from the grid origin).
    pub fn interpolate(&self, data: &[f32], p: DVec3) -> f32 {
        self.trilinear(p.as_vec3())
            .map_or(0.0, |(idx, w)| (0..8).map(|k| data[idx[k]] * w[k]).sum())
    }

    /// Each part's density as it counts in choosing which part scatters ([`Fetch::shown`]) at
    /// `p` (cell units from the grid origin), the cells' chances of showing wood `chances`
    /// ([`Level::wood_chances`]): what [`Level::fetch`] reads, for a bake that fits against
    /// it before the level holds its channel.
    pub fn shown_at(&self, chances: &[f32], p: DVec3) -> [f32; 2] {
        self.trilinear(p.as_vec3()).map_or([0.0; 2], |(idx, w)| {
            let density = [0, 1].map(|part| self.weighted_density(part, &idx, &w));
            self.shown(density, chances, (&idx, &w))
        })
    }

    /// Each cell's extinction times its chance of showing wood ([`wood_chance`]) where the
    /// cells show the wood `shown` ([`Level::wood_shown`], or a bake's before the level holds
    /// it), which [`Level::fetch_at`] interpolates; empty where `shown` is.
    pub fn wood_chances(&self, shown: &[f32]) -> Vec<f32> {
        (0..shown.len())
            .map(|i| wood_chance(self.density[0][i], self.density[1][i], shown[i]))
            .collect()
    }

    /// [`Fetch::shown`] at a point of densities `density` between the cells `idx` (trilinear
    /// weights `w`): the cells' `chances` interpolated where both parts are there.
    #[inline(always)]
    fn shown(
        &self,
        density: [f32; 2],
        chances: &[f32],
        (idx, w): (&[usize; 8], &[f32; 8]),
    ) -> [f32; 2] {
        let wood = (density[0] > 0.0 && density[1] > 0.0 && !chances.is_empty())
            .then(|| (0..8).map(|k| chances[idx[k]] * w[k]).sum());
        shown_of(density, wood, self.wood_weight)
    }

    /// Both parts' densities at `c` (cell units from the grid origin): what shadow rays need.
    #[inline]
    pub fn density_at(&self, c: Vec3) -> [f32; 2] {
        let Some((idx, w)) = self.trilinear(c) else {
            return [0.0; 2];
        };
        std::array::from_fn(|p| self.weighted_density(p, &idx, &w))
    }

    /// Part `p`'s density from trilinear cells and weights: the one sum every query makes,
    /// so all of them read the same bits.
    #[inline(always)]
    fn weighted_density(&self, p: usize, idx: &[usize; 8], w: &[f32; 8]) -> f32 {
        let density = &self.density[p];
        (0..8).map(|k| density[idx[k]] * w[k]).sum()
    }

    /// What a renderer's sample reads at `c`, from one set of trilinear weights: both
    /// densities, and a part's gradient only where it has density; the wood's albedo likewise
    /// (the foliage's baked albedo is not read: a species' seasonal colour replaces it). Leaf
    /// moments, needed only by a lit leaf, are [`Level::foliage_leaves`].
    /// One-off: it works out the cells' chances of showing wood, which a renderer keeps
    /// ([`Occupancy::wood_chances`]).
    pub fn fetch(&self, c: Vec3) -> Fetch {
        match Axes::at(c, self.dims) {
            Some(axes) => self.fetch_at(&axes, &self.wood_chances(&self.wood_shown)),
            None => Fetch::default(),
        }
    }

    /// [`Level::fetch`] at the point `axes` were worked out for ([`Axes::at`], with this
    /// level's dimensions), the cells' chances of showing wood `chances`
    /// ([`Level::wood_chances`]).
    #[inline]
    pub fn fetch_at(&self, axes: &Axes, chances: &[f32]) -> Fetch {
        let (idx, w) = self.stencil(axes);
        let mut f = Fetch::default();
        for p in 0..2 {
            f.density[p] = self.weighted_density(p, &idx, &w);
        }
        for p in 0..2 {
            if f.density[p] <= 0.0 {
                continue;
            }
            let gradient = &self.gradient[p];
            for k in 0..8 {
                f.gradient[p] += Vec3::from(gradient[idx[k]]) * w[k];
            }
        }
        if f.density[0] > 0.0 {
            let albedo = &self.albedo[0];
            for k in 0..8 {
                f.wood_albedo += Vec3::from(albedo[idx[k]]) * w[k];
            }
        }
        f.shown = self.shown(f.density, chances, (&idx, &w));
        f
    }

    /// The foliage's density at `c` and, where it has some, its leaf-normal moment: the mean
    /// of its cells' moments weighted by the foliage each holds there (trilinear weight times
    /// density), as the wood's are ([`Level::wood_normals_at`]): an empty cell's placeholder
    /// stands for no leaf. Weighted by the trilinear weights alone, the placeholders' sphere of
    /// normals darkened the lone trees' unshadowed leaves (the conifer lit 60 degrees from the
    /// eye, from above: 0.87 of its mesh's light, 0.93 so weighted) and hid that their own
    /// shadow let too much sun through under a high sun, until the self-shadowing factors
    /// were fitted per height of the sun (texel 1.5; README, *The leaves' self-shadowing by
    /// the sun's height*).
    #[inline]
    pub fn foliage_leaves(&self, c: Vec3) -> Option<(f32, [f32; 6])> {
        self.moment_by_density(1, &self.leaves, c)
    }

    /// The wood's density at `c` and, where it has some and the level has wood moments, its
    /// normal moment: the mean of its cells' moments weighted by the wood each holds there
    /// (trilinear weight times density), as the mip chain and the renderer's sum over trees
    /// weigh them. A cell without wood holds a placeholder ([`ISOTROPIC_LEAVES`]) that stands
    /// for no surface; weighted by the trilinear weights alone, a branch a cell wide, whose
    /// neighbours are mostly empty, took up to seven eighths of a sphere's normals, and under a
    /// high sun a sphere is lit where an upright branch is not (the fixture bare tree alone, lit
    /// 60 degrees from the eye: 1.12 of its mesh's light without shadows, 1.02 so weighted).
    #[inline]
    pub fn wood_normals_at(&self, c: Vec3) -> Option<(f32, [f32; 6])> {
        if self.wood_normals.is_empty() {
            return None;
        }
        self.moment_by_density(0, &self.wood_normals, c)
    }

    /// Part `part`'s density at `c` and, where it has some, the mean of its cells' `moments`
    /// weighted by the part's density each holds there (trilinear weight times density).
    #[inline]
    fn moment_by_density(
        &self,
        part: usize,
        moments: &[[f32; 6]],
        c: Vec3,
    ) -> Option<(f32, [f32; 6])> {
        let (idx, w) = self.trilinear(c)?;
        let d = self.weighted_density(part, &idx, &w);
        if d <= 0.0 {
            return None;
        }
        let (density, per_density) = (&self.density[part], 1.0 / d);
        let mut sum = [0.0f32; 6];
        for k in 0..8 {
            let weight = w[k] * density[idx[k]] * per_density;
            for (sum, m) in sum.iter_mut().zip(&moments[idx[k]]) {
                *sum += m * weight;
            }
        }
        Some((d, sum))
    }
}

/// Per cell `i` of a level, whether the trilinear stencil whose lowest corner is `i` (the
/// eight cells [`Level::trilinear`] reads at any point whose lower neighbours are `i`) holds
/// density of either part, one bit each. Trees are mostly air: a query that looks here first
/// reads no cell of an empty stencil, whose density is exactly 0 whatever the weights.
#[derive(Clone, Debug)]
pub struct Stencils {
    dims: [usize; 3],
    bits: Vec<u64>,
}

impl Stencils {
    pub fn of(level: &Level) -> Stencils {
        let [nx, ny, nz] = level.dims;
        let filled = |i: usize| level.holds_cell(i);
        let mut bits = vec![0u64; level.cell_count().div_ceil(64)];
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    let held = (z..=(z + 1).min(nz - 1)).any(|z| {
                        (y..=(y + 1).min(ny - 1)).any(|y| {
                            (x..=(x + 1).min(nx - 1)).any(|x| filled(level.index(x, y, z)))
                        })
                    });
                    let i = level.index(x, y, z);
                    bits[i / 64] |= u64::from(held) << (i % 64);
                }
            }
        }
        Stencils {
            dims: level.dims,
            bits,
        }
    }

    /// Every stencil marked as holding density: queries that skip nothing.
    pub fn full(level: &Level) -> Stencils {
        Stencils {
            dims: level.dims,
            bits: vec![u64::MAX; level.cell_count().div_ceil(64)],
        }
    }

    /// The dimensions of the level these stencils are of.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// Whether the trilinear field can be non-zero at `c` (cell units from the grid origin):
    /// false outside the grid (and at a non-finite point), where [`Level::trilinear`] reads
    /// nothing, and where the stencil at `c` is empty.
    #[inline]
    pub fn holds(&self, c: Vec3) -> bool {
        Axes::at(c, self.dims).is_some_and(|axes| self.holds_at(&axes))
    }

    /// [`Stencils::holds`] at the point `axes` were worked out for (with these stencils'
    /// dimensions): a sample that goes on to [`Level::fetch_at`] works them out once.
    #[inline]
    pub fn holds_at(&self, axes: &Axes) -> bool {
        let d = self.dims;
        debug_assert_eq!(axes.dims, d, "axes worked out for another grid");
        let [(x, ..), (y, ..), (z, ..)] = axes.along;
        let i = x + d[0] * (y + d[1] * z);
        self.bits[i / 64] >> (i % 64) & 1 != 0
    }

    /// [`Level::density_at`] of the `level` these stencils are of, the same values bit for
    /// bit, without reading the cells of an empty stencil.
    #[inline]
    pub fn density_at(&self, level: &Level, c: Vec3) -> [f32; 2] {
        if self.holds(c) {
            level.density_at(c)
        } else {
            [0.0; 2]
        }
    }
}

/// A cell's extinction times its chance of showing wood, `(a + b) s / (s + b)` for wood and
/// foliage densities `a`, `b` and shown wood `s` ([`Level::wood_shown`]): a uniform mixture
/// of `s` and `b` shows wood with chance `s / (s + b)`, what the mesh shows in the cell. A
/// point weighs its cells' chances by the extinction each gives it (`formats/texel.md`, *Wood
/// shown per cell*), so these interpolate. Interpolating `s` itself, as this renderer did
/// before, let a trunk's cell, whose shown wood is up to 64 times its density, lend its wood
/// to the leafy cells around it, where the mesh shows leaves: the fixture forest's coarse
/// levels showed 1.4 (level 2) to 2.3 (level 3) times their mesh's wood light, and the
/// foliage lost as much.
#[inline]
pub fn wood_chance(a: f32, b: f32, s: f32) -> f32 {
    let chosen = s + b;
    // A cell of neither part stands for nothing.
    if chosen > 0.0 {
        (a + b) * (s / chosen)
    } else {
        0.0
    }
}

/// Each part's density as it counts in choosing which part scatters, at a point of densities
/// `density`: the wood alone or the foliage alone where it is the only part; where both are,
/// the extinction split by the interpolated [`wood_chance`]s (`wood`), or without them (files
/// before texel 1.7) the wood weighted by the level's `wood_weight`.
#[inline]
fn shown_of(density: [f32; 2], wood: Option<f32>, wood_weight: f32) -> [f32; 2] {
    match (density, wood) {
        ([a, b], _) if a <= 0.0 || b <= 0.0 => [a.max(0.0), b.max(0.0)],
        ([a, b], Some(wood)) => {
            let sigma = a + b;
            // Rounding may put the interpolated chances a hair beyond the extinction; the max
            // also keeps an overflowed one (infinite less infinite) out of the choice.
            let wood = wood.clamp(0.0, sigma);
            [wood, (sigma - wood).max(0.0)]
        }
        ([a, b], None) => [a * wood_weight, b],
    }
}

/// A level whose density queries skip empty space ([`Stencils`]).
pub struct Sparse<'a> {
    pub level: &'a Level,
    stencils: Stencils,
}

impl<'a> Sparse<'a> {
    pub fn new(level: &'a Level) -> Sparse<'a> {
        Sparse {
            level,
            stencils: Stencils::of(level),
        }
    }

    /// [`Level::density_at`], the same values bit for bit, without reading the cells of an
    /// empty stencil.
    #[inline]
    pub fn density_at(&self, c: Vec3) -> [f32; 2] {
        self.stencils.density_at(self.level, c)
    }
}

impl std::ops::Deref for Sparse<'_> {
    type Target = Level;
    fn deref(&self) -> &Level {
        self.level
    }
}

/// Cells along each side of an [`Occupancy`] brick.
pub const BRICK: usize = 4;
/// Levels at most this many bricks along every axis are marched without looking at their
/// bricks: a walk over so few costs about what the samples it would save do.
const SMALL_BRICKS: usize = 4;

/// Which bricks of a level (`BRICK`^3 cells) can hold density, for marches that jump over empty
/// space: a brick is occupied when any cell within one cell of it holds density of either part,
/// so that the trilinear reconstruction is exactly 0 everywhere in an empty brick and half a
/// cell beyond it. A march may then skip an empty brick's whole length: what it skips
/// contributes exactly nothing, so the estimate stays what it was (pbrt-v4's majorant grid is
/// the general form; a tree needs only "empty or not").
#[derive(Clone, Debug)]
pub struct Occupancy {
    dims: [usize; 3],
    occupied: Vec<bool>,
    /// Marched without looking at the bricks: every brick occupied (dense crowns), or so few
    /// bricks that a walk over them costs what it saves (coarse levels).
    full: bool,
    /// Within occupied bricks, the cells a sample must read (`Stencils::holds`).
    pub stencils: Stencils,
    /// The level's [`Level::wood_chances`], worked out once.
    pub wood_chances: Vec<f32>,
    /// How much of each of the level's parts faces a view, worked out once.
    pub part_facing: PartFacing,
}

impl Occupancy {
    pub fn of(level: &Level) -> Occupancy {
        let dims = level.dims.map(|n| n.div_ceil(BRICK));
        let mut occupied = vec![false; dims.iter().product()];
        // The bricks whose cells, widened by one, include cell `x`.
        let bricks =
            |x: usize, n: usize| x.saturating_sub(1) / BRICK..=((x + 1) / BRICK).min(n - 1);
        let [nx, ny, nz] = level.dims;
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    if !level.holds_cell(level.index(x, y, z)) {
                        continue;
                    }
                    for bz in bricks(z, dims[2]) {
                        for by in bricks(y, dims[1]) {
                            for bx in bricks(x, dims[0]) {
                                occupied[bx + dims[0] * (by + dims[1] * bz)] = true;
                            }
                        }
                    }
                }
            }
        }
        let full = occupied.iter().all(|&o| o) || dims.iter().all(|&d| d <= SMALL_BRICKS);
        Occupancy {
            dims,
            occupied,
            full,
            stencils: Stencils::of(level),
            wood_chances: level.wood_chances(&level.wood_shown),
            part_facing: PartFacing::of(level),
        }
    }

    /// Every brick occupied: a march that skips nothing (to measure what skipping saves).
    pub fn dense(level: &Level) -> Occupancy {
        let dims = level.dims.map(|n| n.div_ceil(BRICK));
        Occupancy {
            dims,
            occupied: vec![true; dims.iter().product()],
            full: true,
            stencils: Stencils::full(level),
            wood_chances: level.wood_chances(&level.wood_shown),
            part_facing: PartFacing::of(level),
        }
    }

    /// The fraction of bricks that can hold density.
    pub fn fill(&self) -> f64 {
        self.occupied.iter().filter(|&&o| o).count() as f64 / self.occupied.len() as f64
    }

    /// Along the ray `c0 + dc t` (the level's cell coordinates) from `t`: whether the brick
    /// there is occupied, and until where the answer holds (the end of the run of bricks like
    /// it), never past `t_end`. A digital differential analyser over the bricks (Amanatides
    /// and Woo).
    pub fn span(&self, c0: Vec3, dc: Vec3, t: f32, t_end: f32) -> (bool, f32) {
        if self.full {
            return (true, t_end);
        }
        let b = BRICK as f32;
        let p = (c0 + dc * t) / b;
        if !p.is_finite() {
            return (true, t_end);
        }
        let mut idx = [0i64; 3];
        let mut next = [f32::INFINITY; 3];
        let mut delta = [f32::INFINITY; 3];
        let mut step = [0i64; 3];
        for a in 0..3 {
            // Truncation, not floor: they differ only below 0, which clamps to 0 either way
            // (and floor is a call into libm on baseline x86-64).
            idx[a] = (p[a] as i64).clamp(0, self.dims[a] as i64 - 1);
            if dc[a] != 0.0 {
                let inv = 1.0 / dc[a];
                let up = dc[a] > 0.0;
                step[a] = if up { 1 } else { -1 };
                next[a] = ((idx[a] + i64::from(up)) as f32 * b - c0[a]) * inv;
                delta[a] = b * inv.abs();
            }
        }
        let at = |idx: [i64; 3]| {
            self.occupied[idx[0] as usize
                + self.dims[0] * (idx[1] as usize + self.dims[1] * idx[2] as usize)]
        };
        // The brick the ray is in just after `t` (at a face, `t` may round into the one
        // before: a brick met for no length is passed over).
        let mut first = at(idx);
        loop {
            let a = if next[0] <= next[1] && next[0] <= next[2] {
                0
            } else if next[1] <= next[2] {
                1
            } else {
                2
            };
            let cross = next[a];
            if cross >= t_end {
                return (first, t_end);
            }
            let met = cross > t;
            idx[a] += step[a];
            if idx[a] < 0 || idx[a] >= self.dims[a] as i64 {
                // Out of the grid: nothing beyond.
                return if met && first {
                    (true, cross)
                } else {
                    (false, t_end)
                };
            }
            next[a] += delta[a];
            let here = at(idx);
            if !met {
                first = here;
            } else if here != first {
                return (first, cross);
            }
        }
    }
}

/// What one point of a texture holds, per part (`[wood, foliage]`).
#[derive(Clone, Copy, Debug, Default)]
pub struct Fetch {
    pub density: [f32; 2],
    /// Each part's density as it counts in choosing which part scatters, `[wood, foliage]`:
    /// where both parts are, their extinction split by the cells' chances of showing wood
    /// ([`wood_chance`]), or in files before texel 1.7 the wood's density times
    /// [`Level::wood_weight`] and the foliage's.
    pub shown: [f32; 2],
    pub gradient: [Vec3; 2],
    pub wood_albedo: Vec3,
}

/// Outward unit normal from a density gradient (`-g / |g|`), or `None` where the gradient
/// vanishes (uniform interiors, empty space, isolated symmetric cells): there is no preferred
/// direction to shade with, and a renderer uses a direction-free term instead.
pub fn normal(gradient: [f32; 3]) -> Option<[f32; 3]> {
    let [x, y, z] = gradient.map(|c| c as f64);
    let length = (x * x + y * y + z * z).sqrt();
    (length > 1e-12 && length.is_finite())
        .then(|| [-x / length, -y / length, -z / length].map(|c| c as f32))
}

/// The parameters a bake was run with, recorded so a texture can be re-made or compared.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BakeParameters {
    /// Texture cells along the longest side of the model.
    pub resolution: u32,
    /// Fine cells along the longest side of the model.
    pub fine: u32,
    /// Case-insensitive regular expression on material names that marks foliage.
    pub foliage_pattern: String,
    /// gamma (1/m) given on the command line; `None` = fitted automatically (occupancy only).
    pub requested_gamma: Option<f64>,
    /// Case-insensitive regular expression on material names that marks wood whatever else
    /// says foliage (`--wood`); `None` where none was given (and in files before v1.1).
    pub wood_pattern: Option<String>,
}

/// Where a material of the model went: wood or foliage, and why.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MaterialPart {
    pub name: String,
    pub foliage: bool,
    pub reason: PartReason,
    /// Share of the material's surface its alpha (`MASK` or `BLEND`) removes.
    pub cut: f32,
    /// Triangles of the model drawn with it.
    pub triangles: u64,
}

/// Why a material is wood or foliage, in the order the rules are tried.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PartReason {
    /// Wood: its name matches the `--wood` pattern.
    WoodPattern,
    /// Foliage: its name matches the `--foliage` pattern.
    FoliagePattern,
    /// Foliage: its alpha removes part of its surface (leaf cards).
    AlphaCuts,
    /// Wood: nothing says foliage.
    Solid,
}

impl PartReason {
    pub fn describe(self) -> &'static str {
        match self {
            PartReason::WoodPattern => "name matches --wood",
            PartReason::FoliagePattern => "name matches --foliage",
            PartReason::AlphaCuts => "alpha cuts leaf shapes",
            PartReason::Solid => "solid",
        }
    }
}

/// Everything about a texture but its voxels.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TexelInfo {
    pub generator: String,
    /// Bounds of the model's triangles, model space, metres.
    pub model_min: [f64; 3],
    pub model_max: [f64; 3],
    /// Minimum corner of every level's grid, model space, metres.
    pub origin: [f64; 3],
    pub density_model: DensityModel,
    /// gamma: extinction (1/m) = gamma x density. 1 for the transmittance model.
    pub extinction_scale: f64,
    pub triangles: u64,
    pub foliage_triangles: u64,
    /// Fraction of the rays parallel to x, y and z, one per fine cell over the grid's face, that
    /// hit the mesh: the silhouette coverage the texture is calibrated to.
    pub mesh_coverage: [f64; 3],
    pub sources: Vec<SourceFile>,
    /// SHA-256 over the SHA-256 of every source, in order.
    #[serde(serialize_with = "crate::hex::hex32")]
    pub inputs_sha256: [u8; 32],
    pub parameters: BakeParameters,
    /// How each material of the model divided between wood and foliage (empty in files
    /// before v1.1).
    pub materials: Vec<MaterialPart>,
}

impl TexelInfo {
    /// Where the texture records no model it was baked from (a procedural one, say), why
    /// that stops `what`, for an error about its file: both a mesh render and an export need
    /// the glTF.
    pub fn no_source_model(&self, what: &str) -> Option<String> {
        self.sources.is_empty().then(|| {
            format!(
                "records no source model (made by {:?}); {what} the glTF it was baked from",
                self.generator
            )
        })
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Texel {
    pub info: TexelInfo,
    /// Finest first; each level halves the previous (rounding up) down to a single cell.
    pub levels: Vec<Level>,
}

impl Texel {
    pub fn origin(&self) -> DVec3 {
        DVec3::from(self.info.origin)
    }

    /// The box (model units) the grids of all levels fill, from the origin to the farthest
    /// far corner: where the renderer draws the tree, whatever the recorded model box says.
    pub fn grid_box(&self) -> (DVec3, DVec3) {
        let o = self.origin();
        let hi = self.levels.iter().fold(o, |hi, l| {
            let dims = DVec3::new(l.dims[0] as f64, l.dims[1] as f64, l.dims[2] as f64);
            hi.max(o + dims * l.cell)
        });
        (o, hi)
    }

    /// Extinction (1/m) of both parts at model-space point `p` on level `level`, along the
    /// direction `dir` (model space), as a view ray sees it: each part turned by `facing`,
    /// the level's [`PartFacing`] (worked out once by the caller); inside a solid (full
    /// foliage), [`SOLID_EXTINCTION`].
    pub fn extinction(&self, level: usize, facing: &PartFacing, p: DVec3, dir: DVec3) -> f32 {
        let l = &self.levels[level];
        let q = (p - self.origin()) / l.cell;
        if l.in_solid(q.as_vec3(), 1.0) {
            return SOLID_EXTINCTION;
        }
        let dir = dir.as_vec3();
        let s = self.info.extinction_scale as f32 * l.directional_factor(dir);
        let [to_wood, to_foliage] = facing.along(dir);
        s * (l.interpolate(&l.density[0], q) * to_wood
            + l.interpolate(&l.density[1], q) * to_foliage)
    }

    /// The share of the view along `axis` the finest level blocks: the mean over its columns
    /// of `1 - exp(-depth)` (what `bake` measures of the mesh as `mesh_coverage`).
    pub fn texture_coverage(&self, axis: usize) -> f64 {
        let d = self.column_depths(0, axis);
        d.iter().map(|t| 1.0 - (-t).exp()).sum::<f64>() / d.len().max(1) as f64
    }

    /// Optical depth of every column of cells of `level` along `axis`, in the model's units,
    /// as a view ray along the axis sees it (the level's directional factor, each part turned
    /// by its [`PartFacing`]): the silhouette the texture casts along the axis is
    /// `1 - exp(-depth)`. Where the level has solids (full foliage), the share of the column
    /// they block (at 4 x 4 lines across it: along a line the field is linear between the
    /// planes of cell centres, so a line reaches the level where it does at one of them) adds
    /// `-ln(1 - share)`.
    pub fn column_depths(&self, level: usize, axis: usize) -> Vec<f64> {
        let l = &self.levels[level];
        let mut w = Vec3::ZERO;
        w[axis] = 1.0;
        let k = l.directional_factor(w);
        let turn = PartFacing::of(l).along(w);
        self.columns(level, axis, turn.map(|t| k * t))
    }

    /// [`Texel::column_depths`] of the densities alone, both parts alike, without the
    /// directional factor: what the scans measured.
    pub fn scanned_column_depths(&self, level: usize, axis: usize) -> Vec<f64> {
        self.columns(level, axis, [1.0; 2])
    }

    /// The columns' optical depths with each part's density times `by`.
    fn columns(&self, level: usize, axis: usize, by: [f32; 2]) -> Vec<f64> {
        let l = &self.levels[level];
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let mut depth = vec![0.0; l.dims[u] * l.dims[v]];
        let s = self.info.extinction_scale * l.cell;
        for z in 0..l.dims[2] {
            for y in 0..l.dims[1] {
                for x in 0..l.dims[0] {
                    let c = [x, y, z];
                    let i = l.index(x, y, z);
                    depth[c[u] + l.dims[u] * c[v]] +=
                        s * (l.density[0][i] * by[0] + l.density[1][i] * by[1]) as f64;
                }
            }
        }
        if l.has_solid() {
            const LINES: usize = 4;
            for cv in 0..l.dims[v] {
                for cu in 0..l.dims[u] {
                    let mut blocked = 0;
                    for line in 0..LINES * LINES {
                        let mut p = Vec3::ZERO;
                        p[u] = cu as f32 + ((line % LINES) as f32 + 0.5) / LINES as f32;
                        p[v] = cv as f32 + ((line / LINES) as f32 + 0.5) / LINES as f32;
                        blocked += usize::from((0..l.dims[axis]).any(|k| {
                            p[axis] = k as f32 + 0.5;
                            l.in_solid(p, 1.0)
                        }));
                    }
                    let open = 1.0 - blocked as f64 / (LINES * LINES) as f64;
                    depth[cu + l.dims[u] * cv] -= open.ln();
                }
            }
        }
        depth
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// What counts of the wood in choosing which part scatters: where both parts have density
    /// (texel 1.7), the shown wood that gives the cells' chances of showing wood weighted by
    /// their extinction there; the wood itself where it is the only part; and the level's
    /// weight on the wood without the channel.
    #[test]
    fn the_wood_shown_is_read_where_both_parts_are() {
        let mut l = Level::empty([2, 1, 1], 1.0);
        l.density = [vec![2.0, 2.0], vec![1.0, 0.0]];
        l.wood_weight = 3.0;
        let at = |l: &Level, x: f32| l.fetch(Vec3::new(x, 0.5, 0.5)).shown;
        // Between the centres: foliage 0.5, wood 2.
        assert_eq!(at(&l, 1.0), [6.0, 0.5]);
        assert_eq!(at(&l, 1.5), [2.0, 0.0], "no foliage: the wood itself");
        l.wood_shown = vec![0.5, 4.0];
        let chance = |[wood, foliage]: [f32; 2]| wood / (wood + foliage);
        assert!(
            (chance(at(&l, 0.5)) - 0.5 / 1.5).abs() < 1e-6,
            "a cell's centre: its own"
        );
        // Halfway: the cells' chances 1/3 and 1, weighted by their extinction 3 and 2. The
        // shown wood interpolated (2.25 against foliage 0.5) would give 0.82: the wood-only
        // cell's weight lent to its leafy neighbour.
        assert!((chance(at(&l, 1.0)) - 0.6).abs() < 1e-6);
        assert_eq!(at(&l, 1.5), [2.0, 0.0], "no foliage: the wood itself");
        // Cells that agree on the chance: the interpolated shown wood's.
        l.density = [vec![2.0, 4.0], vec![1.0, 2.0]];
        l.wood_shown = vec![1.0, 2.0];
        assert!((chance(at(&l, 1.0)) - 1.5 / 3.0).abs() < 1e-6);
        l.density[1] = vec![0.0, 0.0];
        assert_eq!(at(&l, 1.0), [3.0, 0.0], "no foliage: the wood itself");
    }

    /// Each part's extinction along a view turns with its surfaces' projected area: flat
    /// leaves block most from above, upright branches from the side; the level's total, each
    /// part weighted by its density, is what the directional form was fitted to, in every
    /// direction; parts that face every way alike, and files without wood normals, keep
    /// their extinction.
    #[test]
    fn each_part_blocks_a_view_as_its_surfaces_face_it() {
        let mut l = Level::empty([2, 1, 1], 1.0);
        l.density = [vec![1.0, 0.0], vec![0.0, 3.0]];
        // Branches standing along y (a cylinder's normals), leaves lying flat.
        l.wood_normals = vec![[0.5, 0.0, 0.5, 0.0, 0.0, 0.0]; 2];
        l.leaves = vec![[0.0, 1.0, 0.0, 0.0, 0.0, 0.0]; 2];
        let facing = PartFacing::of(&l);
        let near = |a: f32, b: f32| (a - b).abs() < 1e-5;
        // From above: the leaves' full area (root 3 over an isotropic part's), the branches'
        // none (held at a quarter); the mean (0.25 + 3 root 3) / 4.
        let [wood, foliage] = facing.along(Vec3::Y);
        let mean = (0.25 + 3.0 * 3f32.sqrt()) / 4.0;
        assert!(near(wood, 0.25 / mean) && near(foliage, 3f32.sqrt() / mean));
        // From the side: the branches' root 1.5, the leaves' none.
        let [wood, foliage] = facing.along(Vec3::new(-2.0, 0.0, 0.0));
        let mean = (1.5f32.sqrt() + 3.0 * 0.25) / 4.0;
        assert!(near(wood, 1.5f32.sqrt() / mean) && near(foliage, 0.25 / mean));
        for d in [
            Vec3::X,
            Vec3::Y,
            Vec3::new(1.0, 2.0, -0.5),
            Vec3::new(0.3, -1.0, 3.0),
        ] {
            let [wood, foliage] = facing.along(d);
            assert!(
                near(wood + 3.0 * foliage, 4.0),
                "{d}: the level's total kept"
            );
        }
        assert_eq!(facing.along(Vec3::ZERO), [1.0, 1.0]);
        l.wood_normals = vec![ISOTROPIC_LEAVES; 2];
        l.leaves = vec![ISOTROPIC_LEAVES; 2];
        let [wood, foliage] = PartFacing::of(&l).along(Vec3::new(1.0, 2.0, 3.0));
        assert!(near(wood, 1.0) && near(foliage, 1.0), "alike every way");
        l.wood_normals = Vec::new();
        assert_eq!(PartFacing::of(&l), PartFacing::ALIKE, "before texel 1.4");
        assert_eq!(PartFacing::ALIKE.along(Vec3::X), [1.0, 1.0]);
    }

    /// A factor is linear in the angle between eye and sun and in the sun's height between
    /// the stored ones, the height clamped to 0 to 90 degrees; one row serves every height in
    /// files before texel 1.5.
    #[test]
    fn self_shadowing_interpolates_in_the_angle_and_the_suns_height() {
        let row = |h: f32| [0.0, 1.0 + h, 2.0 + h, 4.0 + h, 8.0 + h, 8.0 + h];
        let s = SelfShadow {
            pooled: row(0.0),
            by_height: [row(0.0), row(3.0), row(6.0), row(9.0)],
            by_view: None,
        };
        let at = |s: &SelfShadow, angle: f32, sun_height: f32| {
            s.at(&SunFromEye {
                angle,
                sun_height,
                eye_height: 20.0,
                turn: 0.0,
            })
        };
        let near = |a: f32, b: f32| (a - b).abs() < 1e-4;
        assert!(near(at(&s, 0.0, 0.0), 0.0));
        assert!(near(at(&s, 15.0, 0.0), 1.0));
        // Halfway between the rows for 30 and 60 degrees: 4 and 7.
        assert!(near(at(&s, 15.0, 45.0), 5.5));
        // Halfway between 30 and 60 degrees from the eye, overhead: 11 and 13.
        assert!(near(at(&s, 45.0, 90.0), 12.0));
        assert!(near(at(&s, 15.0, -20.0), at(&s, 15.0, 0.0)));
        assert!(near(at(&s, 15.0, 120.0), at(&s, 15.0, 90.0)));
        let one = SelfShadow::uniform(row(0.0));
        for h in [0.0, 17.0, 45.0, 90.0] {
            assert!(near(at(&one, 45.0, h), 3.0));
        }
    }

    /// Texel 1.6's rows: linear in the eye's height and the sun's turn between the stored
    /// ones, clamped at the ends; the sun's height no longer read.
    #[test]
    fn self_shadowing_by_view_interpolates_in_the_eyes_height_and_the_suns_turn() {
        let row = |k: f32| [0.0, k, k, k, k, k];
        let s = SelfShadow {
            by_view: Some(std::array::from_fn(|e| {
                std::array::from_fn(|t| row(1.0 + 10.0 * e as f32 + t as f32))
            })),
            ..SelfShadow::uniform(row(100.0))
        };
        let at = |eye_height: f32, turn: f32| {
            s.at(&SunFromEye {
                angle: 30.0,
                sun_height: 45.0,
                eye_height,
                turn,
            })
        };
        let near = |a: f32, b: f32| (a - b).abs() < 1e-4;
        assert!(near(at(10.0, 0.0), 1.0));
        assert!(near(at(60.0, 180.0), 23.0));
        // A quarter of the way from 10 to 35 degrees high, halfway from up to beside.
        assert!(near(at(16.25, 45.0), 1.0 + 2.5 + 0.5));
        assert!(near(at(-30.0, 90.0), at(10.0, 90.0)));
        assert!(near(at(85.0, 135.0), 22.5));
    }

    /// Where the sun stands from the eye: angle, heights and the turn about the line of sight,
    /// whose cases are up, beside, below, and undefined (90) where the eye looks straight down.
    #[test]
    fn the_sun_is_placed_about_the_eyes_line_of_sight() {
        let unit = |x: f32, y: f32, z: f32| Vec3::new(x, y, z).normalize();
        let eye = unit(0.0, 1.0, 1.0);
        let s = SunFromEye::new(eye, unit(0.0, 1.0, 0.0));
        assert!(
            // acos near 1 in f32: a few hundredths of a degree.
            (s.angle - 45.0).abs() < 1e-3 && s.turn.abs() < 0.1,
            "{s:?}"
        );
        assert!((s.eye_height - 45.0).abs() < 1e-3 && (s.sun_height - 90.0).abs() < 1e-3);
        assert!((SunFromEye::new(eye, unit(1.0, 1.0, 1.0)).turn - 90.0).abs() < 1e-3);
        assert!((SunFromEye::new(eye, unit(0.0, 0.0, 1.0)).turn - 180.0).abs() < 0.1);
        assert_eq!(SunFromEye::new(Vec3::Y, unit(1.0, 1.0, 0.0)).turn, 90.0);
        assert_eq!(SunFromEye::new(eye, eye).turn, 90.0);
    }

    /// A branch one cell wide among empty cells is read with its own normals wherever its
    /// density reaches: the empty neighbours' placeholders weigh nothing, so between the
    /// branch's cell and an empty one the moment is the branch's exactly, not half a sphere's.
    /// Two branches' cells mix in proportion to the wood each holds at the point.
    #[test]
    fn wood_normals_mix_by_the_wood_each_cell_holds() {
        let mut l = Level::empty([3, 1, 1], 0.5);
        let upright = [0.5, 0.0, 0.5, 0.0, 0.0, 0.0];
        let lying = [0.0, 0.5, 0.5, 0.0, 0.0, 0.0];
        l.wood_normals = vec![upright, ISOTROPIC_LEAVES, lying];
        l.density[0] = vec![2.0, 0.0, 1.0];
        // Halfway from the branch's cell centre to the empty one's: half the density.
        let (d, m) = l.wood_normals_at(Vec3::new(1.0, 0.5, 0.5)).unwrap();
        assert_eq!((d, m), (1.0, upright));
        // A quarter of the way from one branch's cell centre to the next one's: each cell's
        // moment in proportion to its wood there, 2 x 3/4 against 1 x 1/4.
        let mut two = Level::empty([2, 1, 1], 0.5);
        two.wood_normals = vec![upright, lying];
        two.density[0] = vec![2.0, 1.0];
        let (d, m) = two.wood_normals_at(Vec3::new(0.75, 0.5, 0.5)).unwrap();
        assert!((d - 1.75).abs() < 1e-6, "{d}");
        let want: [f32; 6] = std::array::from_fn(|k| (1.5 * upright[k] + 0.25 * lying[k]) / 1.75);
        for k in 0..6 {
            assert!((m[k] - want[k]).abs() < 1e-6, "{m:?} against {want:?}");
        }
        // Where no wood reaches (the empty cell's centre), no moment.
        assert!(l.wood_normals_at(Vec3::new(1.5, 0.5, 0.5)).is_none());
        // The foliage's leaf normals mix the same way, by the foliage each cell holds.
        two.leaves = vec![upright, lying];
        two.density[1] = vec![2.0, 1.0];
        let (d, m) = two.foliage_leaves(Vec3::new(0.75, 0.5, 0.5)).unwrap();
        assert!((d - 1.75).abs() < 1e-6, "{d}");
        for k in 0..6 {
            assert!((m[k] - want[k]).abs() < 1e-6, "{m:?} against {want:?}");
        }
    }

    /// Skipping empty stencils changes no value: a sparse level (a few dense cells, one of
    /// them at a corner, one of wood alone) answers exactly as the level does, everywhere in
    /// and around its box, and a full set of stencils holds wherever the level is read.
    #[test]
    fn sparse_queries_equal_the_levels_bit_for_bit() {
        let mut l = Level::empty([7, 5, 6], 0.25);
        for (i, part, v) in [
            (0, 1, 3.0),
            (l.index(3, 2, 4), 0, 0.5),
            (l.index(6, 4, 5), 1, 7.0),
        ] {
            l.density[part][i] = v;
        }
        let sparse = Sparse::new(&l);
        let full = Stencils::full(&l);
        let mut rng = crate::rng::Stream::new(3, 0);
        let mut skipped = 0;
        for _ in 0..20_000 {
            let c = Vec3::new(
                rng.unit() as f32 * 9.0 - 1.0,
                rng.unit() as f32 * 7.0 - 1.0,
                rng.unit() as f32 * 8.0 - 1.0,
            );
            let (a, b) = (l.density_at(c), sparse.density_at(c));
            assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "at {c}");
            // What a view ray's sample skips when the stencil is empty is exactly nothing.
            if !sparse.stencils.holds(c) {
                assert_eq!(l.fetch(c).density, [0.0; 2], "at {c}");
            }
            assert_eq!(full.holds(c), l.trilinear(c).is_some(), "at {c}");
            skipped += usize::from(a == [0.0; 2]);
        }
        assert!(skipped > 10_000, "mostly empty: {skipped}");
    }

    /// A march that jumps over the bricks `Occupancy` calls empty skips no density: along
    /// random rays through a level with a few dense cells (one alone in a large empty box),
    /// every point inside every skipped stretch reads exactly 0 (its ends may round onto a
    /// face of the grid), and the bricks are mostly empty.
    #[test]
    fn empty_bricks_hold_no_density_anywhere_along_a_ray() {
        let mut l = Level::empty([23, 17, 30], 0.5);
        for (x, y, z, part) in [(11, 8, 15, 1), (0, 0, 0, 0), (22, 16, 29, 1), (5, 16, 3, 0)] {
            let i = l.index(x, y, z);
            l.density[part][i] = 2.5;
        }
        let occupancy = Occupancy::of(&l);
        assert!(occupancy.fill() < 0.2, "{}", occupancy.fill());
        let mut rng = crate::rng::Stream::new(9, 1);
        let mut u = || rng.unit() as f32;
        let mut skipped = 0.0;
        for _ in 0..2000 {
            let a = Vec3::new(u() * 25.0 - 1.0, u() * 19.0 - 1.0, u() * 32.0 - 1.0);
            let b = Vec3::new(u() * 25.0 - 1.0, u() * 19.0 - 1.0, u() * 32.0 - 1.0);
            // Some rays along an axis exactly.
            let dc = if u() < 0.2 {
                Vec3::new(0.0, 0.0, b.z - a.z)
            } else {
                b - a
            };
            let (mut t, end) = (0.0f32, 1.0f32);
            let mut guard = 0;
            while t < end {
                let (occupied, until) = occupancy.span(a, dc, t, end);
                assert!(until > t || until == end, "no progress at {t}");
                if !occupied {
                    for k in 1..16 {
                        let s = t + (until - t) * k as f32 / 16.0;
                        assert_eq!(
                            l.density_at(a + dc * s),
                            [0.0; 2],
                            "density skipped at {s} ({}) in [{t}, {until}) from {a} along {dc}",
                            a + dc * s
                        );
                    }
                    skipped += until - t;
                }
                t = until;
                guard += 1;
                assert!(guard < 1000);
            }
        }
        assert!(skipped > 1000.0, "little skipped: {skipped}");
    }

    /// A field linear in x, y and z is reproduced exactly between cell centres, held at the    /// A field linear in x, y and z is reproduced exactly between cell centres, held at the
    /// edge value in the outer half cell, and empty outside; every channel agrees.
    #[test]
    fn a_linear_field_is_interpolated_exactly_and_clamped_at_the_edges() {
        let dims = [3, 2, 4];
        let mut l = Level::empty(dims, 0.5);
        let f = |x: f32, y: f32, z: f32| 1.0 + 2.0 * x - 0.5 * y + 0.25 * z;
        for i in 0..l.cell_count() {
            let (x, y, z) = (
                (i % 3) as f32 + 0.5,
                ((i / 3) % 2) as f32 + 0.5,
                (i / 6) as f32 + 0.5,
            );
            l.density[0][i] = f(x, y, z);
            l.density[1][i] = 2.0 * f(x, y, z);
            l.albedo[0][i] = [f(x, y, z); 3];
        }
        for p in [
            Vec3::new(0.7, 0.9, 1.1),
            Vec3::new(2.4, 1.5, 3.3),
            Vec3::new(1.5, 0.5, 2.0),
        ] {
            let d = l.density_at(p);
            assert!((d[0] - f(p.x, p.y, p.z)).abs() < 1e-5, "{d:?} at {p}");
            assert!((d[1] - 2.0 * d[0]).abs() < 1e-5);
            let all = l.fetch(p);
            assert_eq!(all.density, d);
            assert!((all.wood_albedo.x - d[0]).abs() < 1e-5);
        }
        // The outer half cell holds the edge value: x = 0.2 reads as x = 0.5.
        assert!((l.density_at(Vec3::new(0.2, 1.0, 2.0))[0] - f(0.5, 1.0, 2.0)).abs() < 1e-5);
        assert_eq!(l.density_at(Vec3::new(-0.1, 1.0, 1.0)), [0.0; 2]);
        assert_eq!(l.density_at(Vec3::new(1.0, 2.1, 1.0)), [0.0; 2]);
    }
}
