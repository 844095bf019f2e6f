//! Optical depth towards the sun, cached per species, level and turn of tree
//! (`--shadows cached`).
//!
//! A shadow ray's optical depth is a sum over the trees it crosses, and each term depends only
//! on where the ray enters that tree's grid: the sun's direction is the same for every shadow
//! ray. So for a tree's texture, level and turn about +Y, one pass against the sun fills a
//! grid with the depth from each point to the grid's sunward side, and a shadow ray reads one
//! trilinear lookup per tree where it marched a dozen samples. The grid is sheared along the
//! sun (each column one ray towards it, summed by the trapezoid rule over the trilinear field
//! a march reads), and at least 32 columns across however coarse the level: a 4-cell level's
//! field changes tenfold from cell to cell, and columns a cell apart read it 30% wrong.
//!
//! Trees share grids: a tree's shadow is drawn at its rotation rounded to one of 64 turns on
//! its finest level, half as many per coarser level (a shift of at most three quarters of a
//! cell at a tree's edge, less nearer its axis).
//! Grids are built on first use, so a frame builds only what its shadow rays reach, and
//! the same whichever thread builds them: images do not depend on the thread count. Their
//! number is bounded by species x levels x turns, not by the number of trees, and their
//! memory by [`MEMORY_BOUND`]: with many species the turns are fewer. Species told apart
//! only by colour share grids.
//!
//! A level with solids (`bake::solid`) keeps, beside the depths, where each column first
//! enters a solid: a shadow map, the opaque part of a deep shadow map (Lokovic and Veach
//! 2000). A lookup past that point in its columns is in the solid's shadow, blended over the
//! four columns around it; depths through a solid, interpolated between columns, would darken
//! a column's width around every solid's shadow.
//!
//! What it changes against `--shadows exact` (a jittered march, unbiased, noisy): no noise in
//! the depth, and with it none of the brightening exp(-depth) takes from a noisy depth; a
//! lookup interpolated between columns, a few percent of a tree's depth at a point, and by
//! transmittance where the columns drift across the field's cells (`Grid::at`): through a
//! sharp field (a level 0's leaves) interpolated depths read up to 14 % dark on average. Nor
//! is it biased at the points a view sees: a seen leaf's shadow ray starts in the gaps the
//! eye sees it through, shallower than the columns around it, so the tree a sample lies in is
//! marched for its first cells and read from its grid only beyond them
//! (`sunlight::NEAR_CELLS`). Its cost is building the grids, which a small frame does not earn
//! back (README, *Measured*).

use std::sync::OnceLock;

use glam::Vec3;

use super::instances::{Instances, TreeTransform};
use super::scene::{Look, Scene};
use super::walk::SIGMA_MAX;
use crate::geom::Ray;
use crate::volume::{Level, SOLID_LEVEL, Texel, clamped_axis, padded_axis};

/// Turns about +Y a tree's rotation is recorded in (per instance, one byte).
const TURNS: usize = 256;

/// How many times the finest level's turns are halved from [`TURNS`] at the least: its
/// shadows are drawn at 64 turns, half as many on each coarser level. A 64th of a turn moves
/// no point of a tree 12 m across by more than 29 cm, three quarters of the finest cell of the
/// fixtures' 32-cell textures. Against 256 turns it adds 0.3-0.6% to the error budget's
/// totals (what the cache adds to them: +3.0 / +4.0 / +2.0% far / middle / near, against
/// +2.6 / +3.2 / +1.7%) and leaves the trees as bright or brighter; a quarter of the grids
/// fit the caches: far view 1.14x and demo frame 1.06x faster (README, *Measured*).
const FINEST_COARSENING: usize = 2;

/// What the grids may take at most, whatever the frame asks for: with many species, each
/// level's turns are halved (all levels alike) until every grid they allow, at
/// [`GRID_BYTES`] each, would fit. Up to 32 casters keep the finest level's 64 turns.
const MEMORY_BOUND: usize = 512 << 20;

/// A grid's bytes, as planned for [`MEMORY_BOUND`]: about 33 layers of 40 x 40 columns of 2
/// bytes, padded to whole blocks of 2 x 2 x 2 (the demo frame's 208 grids average 104 KiB).
const GRID_BYTES: usize = 128 << 10;

/// The deepest optical depth a grid keeps; deeper ones (a texture with an extinction scale
/// near f32's range sums to infinity) are kept as this. exp(-DEEPEST) is 0 in f32: such a tree
/// stops the light whatever else the ray crosses, and the grid's unit stays finite.
const DEEPEST: f32 = 1e4;

/// The depth grids of every look, level and turn, built as shadow rays first reach them.
pub struct SunDepth {
    /// Per caster, level and turn (`(caster * levels + level) * TURNS + turn`), its grid.
    grids: Vec<OnceLock<Grid>>,
    /// Per look, its caster: looks of one texture and foliage weight (species told apart
    /// only by colour) cast the same shadow and share grids.
    casters: Vec<usize>,
    levels: usize,
    /// How many times every level's turns are halved to keep within [`MEMORY_BOUND`].
    coarsen: usize,
    /// Per instance, the turn its shadow is drawn at (of [`TURNS`]).
    turns: Vec<u8>,
    /// Per turn, its cosine and sine.
    cos_sin: Vec<[f32; 2]>,
}

impl SunDepth {
    pub fn new(instances: &Instances, looks: &[Look], texels: &[Texel]) -> SunDepth {
        let levels = texels.iter().map(|t| t.levels.len()).max().unwrap_or(0);
        let turn = |i: u32| {
            let t = instances.get(i);
            let a = t.sin.atan2(t.cos).rem_euclid(std::f32::consts::TAU);
            (a / std::f32::consts::TAU * TURNS as f32).round() as usize % TURNS
        };
        let mut kinds: Vec<(usize, u32)> = Vec::new();
        let casters = looks
            .iter()
            .map(|l| {
                let kind = (l.texel, l.foliage.to_bits());
                kinds.iter().position(|&k| k == kind).unwrap_or_else(|| {
                    kinds.push(kind);
                    kinds.len() - 1
                })
            })
            .collect();
        let coarsen = coarsening(kinds.len(), levels);
        SunDepth {
            grids: (0..kinds.len() * levels * TURNS)
                .map(|_| OnceLock::new())
                .collect(),
            casters,
            levels,
            coarsen,
            turns: (0..instances.len() as u32).map(|i| turn(i) as u8).collect(),
            cos_sin: (0..TURNS)
                .map(|t| {
                    let (sin, cos) = (t as f32 * std::f32::consts::TAU / TURNS as f32).sin_cos();
                    [cos, sin]
                })
                .collect(),
        }
    }

    /// The optical depth through instance `i` at level `level`, its extinction times
    /// `factor`, along `ray` (renderer frame, towards the sun) from its origin to beyond the
    /// tree: read where the ray enters the level's grid, or at its origin inside it. The tree
    /// is turned to its shadow's turn.
    #[inline]
    pub fn depth(&self, scene: &Scene, i: u32, level: usize, ray: &Ray, factor: f32) -> f32 {
        let inst = scene.instances.get(i);
        // Coarser levels' cells are larger: half as many turns per level keeps the largest
        // shift a turn makes to the same part of a cell.
        let shift = (level + self.coarsen).min(8);
        let level_turns = (TURNS >> shift).max(1);
        let turn = ((self.turns[i as usize] as usize + (1 << shift >> 1)) >> shift) % level_turns;
        let [cos, sin] = self.cos_sin[(turn << shift) % TURNS];
        let turned = TreeTransform { cos, sin, ..*inst };
        let look = inst.look as usize;
        let caster = self.casters[look];
        let grid = self.grids[(caster * self.levels + level) * TURNS + turn].get_or_init(|| {
            let texel = &scene.texels[scene.looks[look].texel];
            Grid::new(
                &texel.levels[level],
                texel.origin().as_vec3(),
                texel.info.extinction_scale as f32,
                scene.looks[look].foliage,
                // The turn's alone: with the tree's scale in it, the grid's bits would depend
                // on which tree asked first, and so the image on the thread count.
                TreeTransform {
                    scale: 1.0,
                    ..turned
                }
                .dir_to_model(ray.dir),
            )
        });
        grid.depth_from(turned.to_model(ray.origin), factor)
    }

    /// Whether these grids were made for `instances` drawn with `looks` (as many of each,
    /// the same turns).
    pub fn fits(&self, instances: &Instances, looks: &[Look]) -> bool {
        self.casters.len() == looks.len() && self.turns.len() == instances.len()
    }

    /// How many grids are built, and their bytes.
    pub fn built(&self) -> (usize, usize) {
        let built = self.grids.iter().filter_map(OnceLock::get);
        built.fold((0, 0), |(n, bytes), g| (n + 1, bytes + g.bytes()))
    }
}

/// How many times every level's turns are halved for `casters` kinds of tree of `levels`
/// levels: as few as keep all the grids there could be within [`MEMORY_BOUND`].
fn coarsening(casters: usize, levels: usize) -> usize {
    (FINEST_COARSENING..8)
        .find(|&c| planned_bytes(casters, levels, c) <= MEMORY_BOUND)
        .unwrap_or(8)
}

/// The bytes of every grid there could be, at [`GRID_BYTES`] each, with every level's turns
/// halved `coarsen` times.
fn planned_bytes(casters: usize, levels: usize, coarsen: usize) -> usize {
    let turns: usize = (0..levels).map(|l| (TURNS >> (l + coarsen)).max(1)).sum();
    casters * turns * GRID_BYTES
}

/// Cells of a depth grid per cell of a level of `dims` cells: at least 32 across its
/// largest side. A coarse level's cells are metres across and its trilinear field changes
/// tenfold from one to the next; sampled once per cell along an oblique ray, and read between
/// columns a cell apart, its depths would be off by up to a third.
fn fineness(dims: [usize; 3]) -> f32 {
    let largest = dims.into_iter().max().unwrap_or(1).max(1);
    (32 / largest).clamp(1, 16) as f32
}

/// One tree's optical depths towards the sun at one level, on a grid sheared along the sun:
/// its layers lie across the sun's dominant axis `k` (the level's, `fineness` times finer),
/// but its columns run along the sun, each layer's shifted by `shift` cells across (axes `a`,
/// `b`) from the one below. Each column is one ray towards the sun, so its depths are a
/// running sum along it (by the trapezoid rule, [`substeps`] planes a layer), and nothing is
/// interpolated but the final lookup.
pub(super) struct Grid {
    /// The level's grid: its origin (model space), and in the grid's own cells (`fineness`
    /// to a level cell) their number per metre and its extent.
    origin: Vec3,
    per_metre: f32,
    extent: Vec3,
    /// The sun per model metre in the grid's cells, and its reciprocal (no component zero).
    towards: Vec3,
    inverse: Vec3,
    axes: [usize; 3],
    /// Whether the sun lies towards +k.
    sunward_high: bool,
    /// Cells across per layer towards the sun, and the direction of that layer order along
    /// `k` (+1: the sun is towards +k), folded together.
    shift: [f32; 2],
    /// Where column 0's cell begins across (level cells).
    lo: [f32; 2],
    /// Columns across `a` and `b`, and layers.
    dims: [usize; 3],
    /// The depths in units of `unit`, a 65,535th of the grid's deepest (at most
    /// [`DEEPEST`]): 16 bits halve the bytes a lookup pulls through the cache, which is what
    /// a lookup costs, and are exact to half a unit. In blocks of two columns by two by two
    /// layers ([`place`]), the face after the layers included.
    depth: Box<[u16]>,
    /// Blocks across `a` and `b`.
    blocks: [usize; 2],
    unit: f32,
    /// Per column (`x + dims[0] y`), where along it (in layers) the ray from the sun first
    /// enters a solid, not a number where it enters none; empty for a level without solids.
    /// A shadow map (as a deep shadow map's opaque part): a point past it is in the solid's
    /// shadow, sharp to a column, where depths through a solid interpolated between columns
    /// would darken a column's width around every solid's shadow.
    solid_entry: Box<[f32]>,
    /// Per axis across (`a`, `b`), how far a lookup between two columns goes from their
    /// interpolated depth towards the depth of their interpolated transmittance ([`blend`]).
    blend: [f32; 2],
}

impl Grid {
    /// The optical depth towards the unit model-space direction `sun` from every point of
    /// `level`'s grid to beyond it, for a look whose foliage weight is `foliage` in a texel of
    /// extinction scale `scale`.
    ///
    /// Along a column, from the sunward layer in, each layer's point adds the trapezoid of its
    /// extinction and the one before (the trilinear field at the layer's plane, as a march
    /// reads it: bilinear within the layer, 0 outside the grid); the sunward layer adds half a
    /// layer of its own, the distance to the grid's face.
    pub(super) fn new(level: &Level, origin: Vec3, scale: f32, foliage: f32, sun: Vec3) -> Grid {
        // Held as the march holds it (`SIGMA_MAX`): finite, so that an empty cell's extinction
        // is 0 even for a scale beyond f32's range.
        let sigma_scale = (scale * level.directional_factor(sun)).min(SIGMA_MAX);
        let n = level.dims;
        let fine = fineness(n);
        let k = (0..3)
            .max_by(|&a, &b| sun[a].abs().total_cmp(&sun[b].abs()))
            .unwrap_or(1);
        let (a, b) = ((k + 1) % 3, (k + 2) % 3);
        let step = level.cell as f32 / fine / sun[k].abs();
        // Across per unit along k (sign included).
        let shift = [sun[a] / sun[k], sun[b] / sun[k]];
        let nk = n[k] as f32 * fine;
        let mut lo = [0.0f32; 2];
        let mut dims = [0usize, 0, n[k] * fine as usize];
        for (x, axis) in [a, b].into_iter().enumerate() {
            let m = shift[x] * nk;
            lo[x] = -m.max(0.0);
            dims[x] = (n[axis] as f32 * fine + m.abs()).ceil() as usize;
        }
        // Every layer lies in one plane across k, where the trilinear field is bilinear in a
        // slice of the level interpolated along k: one slice per layer, and each column's
        // point reads 4 values of one channel where a trilinear lookup reads 8 of two.
        let mut slice = Slice::new(level, [a, b, k], sigma_scale, foliage);
        // The layers from the sun's side in, and after them the face the sun's rays enter by
        // (away from the sun).
        let layers: Vec<usize> = if sun[k] > 0.0 {
            (0..dims[2]).rev().collect()
        } else {
            (0..dims[2]).collect()
        };
        let face = if sun[k] > 0.0 { 0.0 } else { nk };
        let columns = dims[0] * dims[1];
        let mut depth = vec![0.0f32; columns * (dims[2] + 1)];
        let (mut sum, mut before) = (vec![0.0f32; columns], vec![0.0f32; columns]);
        // Every column of a layer reads the slice at the same few points across `a` (and a
        // row of them at one across `b`): where, and with what weights, is worked out once.
        let mut taps = Vec::with_capacity(dims[0]);
        // Per column, where along it (layers) the ray from the sun first enters a solid, and
        // the solids' field at the layer before.
        let solids = level.has_solid();
        let mut entry = vec![f32::NAN; if solids { columns } else { 0 }];
        let mut field_before = vec![0.0f32; entry.len()];
        let mut z_before = f32::NAN;
        let mut sweep = |z: f32, layer: Option<usize>, weight: [f32; 2]| {
            slice.fill(z / fine);
            // Column `(ia, ib)` crosses the plane `z` at `q + shift z` fine cells across.
            let across = [0, 1].map(|x| lo[x] + 0.5 + shift[x] * z);
            let [na, nb] = slice.dims();
            taps.clear();
            taps.extend((0..dims[0]).map(|ia| Tap::new((across[0] + ia as f32) / fine, na)));
            for ib in 0..dims[1] {
                let v = Tap::new((across[1] + ib as f32) / fine, nb);
                let row = ib * dims[0]..(ib + 1) * dims[0];
                let cells = taps.iter().zip(&mut sum[row.clone()]);
                for ((u, sum), before) in cells.zip(&mut before[row.clone()]) {
                    let s = slice.at_taps(*u, v);
                    *sum += (weight[0] * s + weight[1] * *before) * step;
                    *before = s;
                }
                if solids {
                    for (ia, u) in taps.iter().enumerate() {
                        let c = row.start + ia;
                        let f = slice.solid_at_taps(*u, v);
                        if entry[c].is_nan() && f >= SOLID_LEVEL {
                            // Where the field crosses the level between this layer and the
                            // one before (linear along the column, as it nearly is).
                            entry[c] = if z_before.is_nan() {
                                z
                            } else {
                                let u = (SOLID_LEVEL - field_before[c]) / (f - field_before[c]);
                                z_before + (z - z_before) * u.clamp(0.0, 1.0)
                            };
                        }
                        field_before[c] = f;
                    }
                }
            }
            // A layer keeps the columns' running sums; a plane between layers only adds to them.
            if let Some(layer) = layer {
                depth[columns * layer..columns * (layer + 1)].copy_from_slice(&sum);
            }
            z_before = z;
        };
        // The trapezoid rule: the sunward layer adds half a layer of its own (the distance to
        // the grid's face), each later plane the mean of it and the one before times the
        // distance between, and the face a quarter of the last layer and of itself (half a
        // layer's distance). A layer is reached in [`substeps`] planes from the one before,
        // and only the layers are kept.
        let subs = substeps(fine);
        let towards_sun = if sun[k] > 0.0 { 1.0 } else { -1.0 };
        let h = 0.5 / subs as f32;
        for (l, &j) in layers.iter().enumerate() {
            let z = j as f32 + 0.5;
            if l == 0 {
                sweep(z, Some(j), [0.5, 0.0]);
                continue;
            }
            for sub in 1..subs {
                let plane = z + towards_sun * (1.0 - sub as f32 / subs as f32);
                sweep(plane, None, [h, h]);
            }
            sweep(z, Some(j), [h, h]);
        }
        sweep(face, Some(dims[2]), [0.25, 0.25]);
        let deepest = depth.iter().fold(0.0f32, |m, &d| m.max(d.min(DEEPEST)));
        let unit = if deepest > 0.0 {
            deepest / f32::from(u16::MAX)
        } else {
            1.0
        };
        let per_metre = fine / level.cell as f32;
        let towards = (sun * per_metre).map(|x| if x.abs() < 1e-20 { 1e-20 } else { x });
        let blocks = [dims[0].div_ceil(2), dims[1].div_ceil(2)];
        let layers = dims[2] + 1;
        let mut blocked = vec![0u16; blocks[0] * blocks[1] * layers.div_ceil(2) * 8];
        for z in 0..layers {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let d = depth[x + dims[0] * (y + dims[1] * z)];
                    blocked[place(blocks, x, y, z)] = (d.min(DEEPEST) / unit + 0.5) as u16;
                }
            }
        }
        Grid {
            origin,
            per_metre,
            extent: Vec3::new(n[0] as f32, n[1] as f32, n[2] as f32) * fine,
            towards,
            inverse: towards.recip(),
            axes: [a, b, k],
            sunward_high: sun[k] > 0.0,
            shift,
            lo,
            dims,
            depth: blocked.into(),
            blocks,
            unit,
            solid_entry: entry.into(),
            blend: blend(lo, shift, fine, dims[2]),
        }
    }

    /// The optical depth, for a tree drawn at `factor` times the extinction the grid was
    /// built for, from the model-space point `p` towards the sun to beyond the grid: read at
    /// `p` inside the grid, else where the ray from it enters the grid (0 if it never does).
    #[inline]
    pub(super) fn depth_from(&self, p: Vec3, factor: f32) -> f32 {
        let c = (p - self.origin) * self.per_metre;
        let (a, b) = (-c * self.inverse, (self.extent - c) * self.inverse);
        let enter = a.min(b).max_element().max(0.0);
        let leave = a.max(b).min_element();
        if enter > leave {
            return 0.0;
        }
        self.at(
            (c + self.towards * enter).clamp(Vec3::ZERO, self.extent),
            factor,
        )
    }

    /// The optical depth at `factor` times the grid's extinction from `p` (the grid's cell
    /// coordinates, inside it) towards the sun.
    ///
    /// Across, between the four columns around `p`, it interpolates their transmittances
    /// (at `factor`: the depth it returns is the tree's as drawn) as far as the columns
    /// drift across the level's cells ([`blend`]), and their depths as far as they stay on
    /// its cell centres. A ray between two columns that cross the field's kinks at every
    /// phase sees each column's light in the share of its weight, and exp(-interpolated
    /// depth) is less than that wherever their depths differ, as a level 0's do a cell
    /// apart: through tree_default_fall's level 0 (five turns of the default sun), the mean
    /// transmittance read by depth is 0.95-0.99 of a fine march's from outside and 0.96-0.98
    /// at random points inside; so read, 1.005-1.013 and 0.984-0.993 (README, *The sun-depth
    /// grid read by transmittance*). A ray between columns on the centres (a sun along a
    /// level's axis) crosses the depth they interpolate.
    #[inline]
    pub(super) fn at(&self, p: Vec3, factor: f32) -> f32 {
        let [a, b, k] = self.axes;
        let z = p[k];
        let x = [
            p[a] - self.shift[0] * z - self.lo[0],
            p[b] - self.shift[1] * z - self.lo[1],
            z,
        ];
        let [(x0, x1, fx), (y0, y1, fy), (z0, z1, fz)] =
            std::array::from_fn(|i| clamped_axis(x[i], self.dims[i]));
        let lit = if self.solid_entry.is_empty() {
            1.0
        } else {
            // The share of the four columns around `p` in whose solid's shadow it is not.
            let open = |x: usize, y: usize| {
                let e = self.solid_entry[x + self.dims[0] * y];
                let shadowed = if self.sunward_high { z < e } else { z > e };
                if shadowed { 0.0 } else { 1.0 }
            };
            let row = |y: usize| open(x0, y) * (1.0 - fx) + open(x1, y) * fx;
            row(y0) * (1.0 - fy) + row(y1) * fy
        };
        if lit <= 0.0 {
            return f32::INFINITY;
        }
        // Each of the four columns' depth at `p`'s height, linear between two layers (along a
        // column it is a running sum), or between a layer and a face; then across, between
        // the columns. Along the sun's axis the layers' centres stop half a cell short of the
        // grid's faces: from the sunward layer the depth falls to 0 at its face, and from the
        // other end it rises to the face the rays enter by, stored after the layers (`None`:
        // the sunward face, 0).
        let n = self.dims[2];
        let (below, above, w) = if z < 0.5 {
            (0, self.sunward_high.then_some(n), (1.0 - 2.0 * z).min(1.0))
        } else if z > n as f32 - 0.5 {
            let u = (2.0 * (z - (n as f32 - 0.5))).min(1.0);
            (n - 1, (!self.sunward_high).then_some(n), u)
        } else {
            (z0, Some(z1), fz)
        };
        let d = &self.depth;
        let column = |x: usize, y: usize| {
            let at = |z: usize| f32::from(d[place(self.blocks, x, y, z)]);
            at(below) * (1.0 - w) + above.map_or(0.0, at) * w
        };
        let scale = factor * self.unit;
        let [ba, bb] = self.blend;
        let row = |y: usize| between(column(x0, y) * scale, column(x1, y) * scale, fx, ba);
        -lit.ln() + between(row(y0), row(y1), fy, bb)
    }

    pub(super) fn bytes(&self) -> usize {
        std::mem::size_of_val(&self.depth[..]) + std::mem::size_of_val(&self.solid_entry[..])
    }
}

/// Where a grid of `blocks` (across `a` and `b`) keeps column `(x, y)`'s depth at layer `z`:
/// in blocks of 2 x 2 x 2 (16 bytes), x fastest within a block and blocks x fastest. By the
/// layout's arithmetic a lookup's eight depths lie in one, two or four rows of blocks (y0 and
/// z0 even, one of them, neither), about 2.4 cache lines, where rows and layers apart they
/// lie in four.
#[inline(always)]
fn place(blocks: [usize; 2], x: usize, y: usize, z: usize) -> usize {
    let block = ((z >> 1) * blocks[1] + (y >> 1)) * blocks[0] + (x >> 1);
    block * 8 + ((z & 1) << 2 | (y & 1) << 1 | (x & 1))
}

/// Planes a column sums per layer: one every quarter of a level cell along the sun's axis.
///
/// Within a plane the trilinear field is linear between the level's cell centres, with a kink
/// at each; between two planes an oblique column drifts across, over kinks the trapezoid
/// rule reads only at its ends. A column's depth so read varies more from column to column
/// than a ray's does, and the mean of exp(-depth) over the columns comes out bright: read by
/// transmittance from outside tree_default_fall's level 0 (baked before the ray-by-ray fit,
/// four turns of the default sun), 1.1-2.6 % at a plane a level cell, 0.5-0.9 % at four.
fn substeps(fine: f32) -> usize {
    (4.0 / fine).max(1.0) as usize
}

/// How far, per axis across, a lookup between two columns of a grid goes from interpolating
/// their depths towards interpolating their transmittances: the mean, along the columns
/// (eight points a layer) and over the pairs of columns a level cell holds, of
/// 6 psi (1 - psi), psi the fraction of the way between the two columns where the level's
/// field has its kink (a cell centre), 0 for a pair with none between them; at most 1.
///
/// Within a plane across the sun's axis the field is linear between the level's cell
/// centres. A ray between two columns with no centre between them crosses the depth they
/// interpolate: a sun in a plane of two of the level's axes keeps the columns on the centres
/// across the third, and read across it by transmittance the sharp fields of
/// `a_sharp_field_lets_through_a_fine_marchs_light_on_average` came out 7-20 % bright with
/// the sun along an axis. Columns that cross the kinks at every phase along their length
/// sample the field as rays taken at random do, whose mean transmittance is what the
/// interpolated transmittances keep; read by depth the same fields came out up to 6.3 %
/// dark. The weight is 1 for phases spread evenly along the columns, 0 for columns on the
/// centres, and about 1 / fineness for finer columns (a kink between one pair in so many).
fn blend(lo: [f32; 2], shift: [f32; 2], fine: f32, layers: usize) -> [f32; 2] {
    const ALONG: usize = 8;
    let per_cell = fine as usize;
    [0, 1].map(|x| {
        let mut sum = 0.0f64;
        for j in 0..layers * ALONG {
            let z = (j as f32 + 0.5) / ALONG as f32;
            for i in 0..per_cell {
                // The pair's first column (level cells), and the first cell centre past it.
                let u = (lo[x] + 0.5 + shift[x] * z + i as f32) / fine;
                let centre = (u - 0.5).floor() + 1.5;
                let psi = f64::from((centre - u) * fine);
                if psi < 1.0 {
                    sum += 6.0 * psi * (1.0 - psi);
                }
            }
        }
        (sum / (layers * ALONG * per_cell).max(1) as f64).min(1.0) as f32
    })
}

/// The depth a fraction `f` of the way from a column of depth `d0` to one of `d1`: `blend` of
/// the way from their interpolated depth to the depth of their interpolated transmittance.
#[inline(always)]
fn between(d0: f32, d1: f32, f: f32, blend: f32) -> f32 {
    let linear = d0 + (d1 - d0) * f;
    // Depths under a thousandth apart interpolate alike either way (to 2e-7), with no exp.
    if blend == 0.0 || (d1 - d0).abs() < 1e-3 {
        return linear;
    }
    // From the shallower column, whose transmittance relative to its own is 1: no
    // transmittance underflows, and one exp serves.
    let (low, deeper, f) = if d0 <= d1 {
        (d0, d1, f)
    } else {
        (d1, d0, 1.0 - f)
    };
    let by_light = low - (f * ((low - deeper).exp() - 1.0)).ln_1p();
    linear + (by_light - linear) * blend
}

/// The trilinear field of a level's combined extinction in one plane across axis `k`, as a
/// march reads it: bilinear across `a` and `b` (level cells), clamped to the edge cells
/// within the grid and 0 outside it.
struct Slice<'l> {
    level: &'l Level,
    axes: [usize; 3],
    scale: f32,
    foliage: f32,
    values: Vec<f32>,
    /// The solids' field `solid_wood + foliage solid_foliage` in the plane; empty where the
    /// level has none.
    solid: Vec<f32>,
}

impl<'l> Slice<'l> {
    fn new(level: &'l Level, axes: [usize; 3], scale: f32, foliage: f32) -> Slice<'l> {
        let [a, b, _] = axes;
        Slice {
            level,
            axes,
            scale,
            foliage,
            values: vec![0.0; level.dims[a] * level.dims[b]],
            solid: if level.has_solid() {
                vec![0.0; level.dims[a] * level.dims[b]]
            } else {
                Vec::new()
            },
        }
    }

    /// Interpolates the slice at `z` level cells along `k`.
    fn fill(&mut self, z: f32) {
        let [a, b, k] = self.axes;
        let n = self.level.dims;
        let (k0, k1, fk) = clamped_axis(z, n[k]);
        let [wood, foliage] = &self.level.density;
        let extinction = |ia: usize, ib: usize, ik: usize| {
            let mut c = [0; 3];
            (c[a], c[b], c[k]) = (ia, ib, ik);
            let i = self.level.index(c[0], c[1], c[2]);
            wood[i] + self.foliage * foliage[i]
        };
        for ib in 0..n[b] {
            for ia in 0..n[a] {
                let e = extinction(ia, ib, k0) * (1.0 - fk) + extinction(ia, ib, k1) * fk;
                // Finite, or an interpolation's weight of 0 on an infinite value would make a
                // NaN.
                self.values[ia + n[a] * ib] = (self.scale * e).min(SIGMA_MAX);
            }
        }
        if !self.solid.is_empty() {
            // Read as `Level::solid_parts_at` reads them: 0 beyond the cells.
            let [wood, foliage] = &self.level.solid;
            let [(k0, w0), (k1, w1)] = padded_axis(z, n[k]);
            let field = |ia: usize, ib: usize, ik: usize| {
                let mut c = [0; 3];
                (c[a], c[b], c[k]) = (ia, ib, ik);
                let i = self.level.index(c[0], c[1], c[2]);
                wood[i] + self.foliage * foliage[i]
            };
            for ib in 0..n[b] {
                for ia in 0..n[a] {
                    self.solid[ia + n[a] * ib] = field(ia, ib, k0) * w0 + field(ia, ib, k1) * w1;
                }
            }
        }
    }

    /// Level cells across `a` and `b`.
    fn dims(&self) -> [usize; 2] {
        let [a, b, _] = self.axes;
        [self.level.dims[a], self.level.dims[b]]
    }

    /// The field at `(u, v)` level cells across `a` and `b`.
    #[cfg(test)]
    fn at(&self, u: f32, v: f32) -> f32 {
        let [na, nb] = self.dims();
        self.at_taps(Tap::new(u, na), Tap::new(v, nb))
    }

    /// The field where the taps `u` across `a` and `v` across `b` read it.
    #[inline]
    fn at_taps(&self, u: Tap, v: Tap) -> f32 {
        if !(u.inside && v.inside) {
            return 0.0;
        }
        self.bilinear(&self.values, u, v)
    }

    /// The solids' field where the taps read it (0 off the slice, and where the level has
    /// none).
    #[inline]
    fn solid_at_taps(&self, u: Tap, v: Tap) -> f32 {
        if self.solid.is_empty() || !(u.inside && v.inside) {
            return 0.0;
        }
        let na = self.dims()[0];
        let mut sum = 0.0;
        for (iv, wv) in v.padded {
            for (iu, wu) in u.padded {
                sum += self.solid[iu + na * iv] * wu * wv;
            }
        }
        sum
    }

    #[inline]
    fn bilinear(&self, values: &[f32], u: Tap, v: Tap) -> f32 {
        let na = self.dims()[0];
        let row = |iv: usize| {
            values[u.low + na * iv] * (1.0 - u.weight) + values[u.high + na * iv] * u.weight
        };
        row(v.low) * (1.0 - v.weight) + row(v.high) * v.weight
    }
}

/// Where a point `x` level cells along one axis of a slice reads it: the two cells and the
/// second's weight, and whether the point lies on the slice at all (the field is 0 off it).
#[derive(Clone, Copy)]
struct Tap {
    low: usize,
    high: usize,
    weight: f32,
    inside: bool,
    /// The cells and weights with the field 0 beyond the cells ([`padded_axis`]), as the
    /// solids are read.
    padded: [(usize, f32); 2],
}

impl Tap {
    #[inline]
    fn new(x: f32, n: usize) -> Tap {
        let (low, high, weight) = clamped_axis(x, n);
        Tap {
            low,
            high,
            weight,
            inside: x >= 0.0 && x <= n as f32,
            padded: padded_axis(x, n),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Stream;

    /// Where the ray `c0 + t dc` (cell units) is first inside the grid `[0, dims]`, from t = 0 on;
    /// `None` if it never is.
    fn entry(c0: Vec3, dc: Vec3, dims: [usize; 3]) -> Option<f32> {
        let (mut lo, mut hi) = (0.0f32, f32::INFINITY);
        for k in 0..3 {
            let n = dims[k] as f32;
            if dc[k] == 0.0 {
                if c0[k] < 0.0 || c0[k] > n {
                    return None;
                }
                continue;
            }
            let (a, b) = ((0.0 - c0[k]) / dc[k], (n - c0[k]) / dc[k]);
            lo = lo.max(a.min(b));
            hi = hi.min(a.max(b));
        }
        (lo <= hi).then_some(lo)
    }

    /// The depth along `sun` from cell point `c` through the level's trilinear field, by a
    /// fine midpoint march: what the sweep approximates.
    fn marched(level: &Level, foliage: f32, sun: Vec3, c: Vec3) -> f32 {
        let cell = level.cell as f32;
        let scale = level.directional_factor(sun);
        let dc = sun / cell;
        let n = 4000;
        let Some(t0) = entry(c, dc, level.dims) else {
            return 0.0;
        };
        let t_exit = {
            // The ray's exit: the far end of the grid's slab along each axis.
            (0..3)
                .filter(|&k| dc[k] != 0.0)
                .map(|k| {
                    let n = level.dims[k] as f32;
                    ((0.0 - c[k]) / dc[k]).max((n - c[k]) / dc[k])
                })
                .fold(f32::INFINITY, f32::min)
        };
        let h = (t_exit - t0) / n as f32;
        (0..n)
            .map(|s| {
                let d = level.density_at(c + dc * (t0 + (s as f32 + 0.5) * h));
                scale * (d[0] + foliage * d[1]) * h
            })
            .sum()
    }

    /// The depth the grid holds at `p`, interpolated between columns as depth: read at a
    /// factor so small that transmittances interpolate as depths do.
    fn held(grid: &Grid, p: Vec3) -> f32 {
        grid.depth_from(p, 1e-4) * 1e4
    }

    /// A smooth cloud of foliage and wood with an empty border, as a bake leaves it.
    fn cloud(dims: [usize; 3]) -> Level {
        let mut l = Level::empty(dims, 0.5);
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let c = Vec3::new(x as f32, y as f32, z as f32) + 0.5;
                    let centre = Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32) / 2.0;
                    let r = ((c - centre) / (centre - 1.0)).length();
                    let i = l.index(x, y, z);
                    l.density[1][i] = (1.0 - r).max(0.0) * 3.0;
                    l.density[0][i] = if r < 0.2 { 2.0 } else { 0.0 };
                }
            }
        }
        l
    }

    /// Anywhere in the grid, for suns along an axis, diagonal, steep and grazing: the cached
    /// depth is the marched one to a few percent of the cloud's depth through its centre,
    /// and unbiased.
    #[test]
    fn the_sweep_matches_a_fine_march_through_a_cloud() {
        let level = cloud([20, 24, 18]);
        let mut s = Stream::new(3, 0);
        for sun in [
            Vec3::Y,
            Vec3::NEG_X,
            Vec3::new(0.3, 0.8, -0.5),
            Vec3::new(-0.7, 0.2, 0.7),
            Vec3::new(0.05, -0.2, 1.0),
            Vec3::new(0.3, -0.2, -0.9),
            Vec3::new(-0.8, 0.4, 0.3),
        ] {
            let sun = sun.normalize();
            let grid = Grid::new(&level, Vec3::ZERO, 1.0, 0.7, sun);
            let scale = marched(&level, 0.7, sun, Vec3::new(10.0, 12.0, 9.0) - sun * 30.0);
            let (mut worst, mut bias) = (0.0f32, 0.0f32);
            for _ in 0..300 {
                let c = Vec3::new(
                    s.unit() as f32 * 20.0,
                    s.unit() as f32 * 24.0,
                    s.unit() as f32 * 18.0,
                );
                let want = marched(&level, 0.7, sun, c);
                let got = held(&grid, c * level.cell as f32);
                worst = worst.max((got - want).abs());
                bias += got - want;
            }
            // Pointwise, the lookup interpolates between columns a cell apart as the texture
            // interpolates between cells (up to 3.3% where the cloud's shadow bends most); on
            // average it has no bias to speak of.
            let bias = bias / 300.0;
            assert!(
                worst < 0.04 * scale && bias.abs() < 0.002 * scale,
                "sun {sun}: worst {worst}, bias {bias} of a depth of {scale} through the centre"
            );
        }
    }

    /// A coarse level (4 cells a side, 3.5 m cells, densities changing tenfold from cell to
    /// cell, dense to its faces, as the fixture broadleaf's level 3 is): read between columns
    /// a cell apart its depths came out 30% low on average; with the grid's finer columns the
    /// mean over the grid is within 2% of a fine march, and no point is off by more than a
    /// tenth of the deepest depth, for two suns.
    #[test]
    fn a_coarse_level_reads_its_depths_from_finer_columns() {
        let mut level = Level::empty([4, 4, 4], 3.5);
        let mut s = Stream::new(17, 0);
        for d in level.density[1].iter_mut() {
            let u = s.unit() as f32;
            *d = 0.16 * u * u * u;
        }
        for sun in [Vec3::new(-0.5, 0.6, 0.62), Vec3::new(0.7, 0.45, -0.2)] {
            let sun = sun.normalize();
            let grid = Grid::new(&level, Vec3::ZERO, 1.0, 1.0, sun);
            let (mut want, mut got, mut worst, mut deepest) = (0.0f64, 0.0f64, 0.0f32, 0.0f32);
            for _ in 0..2000 {
                let c = Vec3::new(s.unit() as f32, s.unit() as f32, s.unit() as f32) * 4.0;
                let (w, g) = (marched(&level, 1.0, sun, c), held(&grid, c * 3.5));
                want += f64::from(w);
                got += f64::from(g);
                worst = worst.max((g - w).abs());
                deepest = deepest.max(w);
            }
            assert!(
                (got / want - 1.0).abs() < 0.02 && worst < 0.1 * deepest,
                "sun {sun}: mean {got} against {want}, worst {worst} of {deepest}"
            );
        }
    }

    /// The fixtures' two casters keep the finest level's 64 turns, and so do 32; 33 halve
    /// them once, 80 twice, and none plans more than the bound unless one turn per level
    /// already would.
    #[test]
    fn many_species_share_the_memory_bound_by_coarser_turns() {
        assert_eq!(coarsening(2, 6), FINEST_COARSENING);
        assert_eq!(coarsening(32, 6), FINEST_COARSENING);
        assert_eq!(coarsening(33, 6), FINEST_COARSENING + 1);
        assert_eq!(coarsening(80, 6), FINEST_COARSENING + 2);
        for casters in 1..200 {
            let c = coarsening(casters, 6);
            assert!(
                planned_bytes(casters, 6, c) <= MEMORY_BOUND || c == 8,
                "{casters}"
            );
            assert!(c == FINEST_COARSENING || planned_bytes(casters, 6, c - 1) > MEMORY_BOUND);
        }
    }

    /// A texture whose extinction overflows f32 (a valid file's scale may be up to f64's):
    /// its grid is opaque in the dense cell's shadow and 0 elsewhere, with no NaN (infinity
    /// times an empty cell) and a finite unit.
    #[test]
    fn an_extinction_beyond_f32_shadows_opaquely_and_only_its_column() {
        let mut level = Level::empty([32, 32, 32], 1.0);
        let i = level.index(8, 4, 8);
        level.density[1][i] = 5.0;
        let grid = Grid::new(&level, Vec3::ZERO, f32::INFINITY, 1.0, Vec3::Y);
        assert!(grid.unit.is_finite());
        for y in 0..4 {
            let below = grid.depth_from(Vec3::new(8.5, y as f32 + 0.5, 8.5), 1.0);
            assert!(below.is_finite() && (-below).exp() == 0.0, "y {y}: {below}");
            assert_eq!(
                grid.depth_from(Vec3::new(7.5, y as f32 + 0.5, 8.5), 1.0),
                0.0
            );
        }
        assert_eq!(grid.depth_from(Vec3::new(8.5, 20.5, 8.5), 1.0), 0.0);
    }

    /// A layer's slice is the level's trilinear field in that plane, as a march reads it:
    /// at any point of planes across each axis, inside, on the faces and outside the grid.
    #[test]
    fn a_slice_reads_the_trilinear_field_in_its_plane() {
        let level = cloud([6, 7, 5]);
        let mut s = Stream::new(9, 0);
        for k in 0..3 {
            let (a, b) = ((k + 1) % 3, (k + 2) % 3);
            let mut slice = Slice::new(&level, [a, b, k], 1.3, 0.7);
            for _ in 0..200 {
                let mut c = Vec3::ZERO;
                for (axis, x) in [a, b, k].into_iter().zip([-0.2, -0.2, 0.0]) {
                    // Across, a little beyond the grid on both sides; along k, within it.
                    let n = level.dims[axis] as f32;
                    c[axis] = x * n + s.unit() as f32 * n * (1.0 - 2.0 * x);
                }
                slice.fill(c[k]);
                let d = level.density_at(c);
                let want = 1.3 * (d[0] + 0.7 * d[1]);
                let got = slice.at(c[a], c[b]);
                assert!(
                    (got - want).abs() < 1e-5 * want.max(1.0),
                    "{c}: {got} against {want}"
                );
            }
        }
    }

    /// A single dense cell in a large empty grid: the sweep carries its depth to the cells
    /// in its shadow and to no other, and its total is the cell's.
    #[test]
    fn a_single_dense_cell_shadows_only_its_column() {
        let mut level = Level::empty([32, 32, 32], 1.0);
        let i = level.index(8, 4, 8);
        level.density[1][i] = 5.0;
        let grid = Grid::new(&level, Vec3::ZERO, 1.0, 1.0, Vec3::Y);
        for y in 0..4 {
            // Below it (away from the sun), the whole cell's trilinear depth: a tent of height
            // 5 and base 2 cells along the axis, area 5 (1 m cells).
            let below = grid.depth_from(Vec3::new(8.5, y as f32 + 0.5, 8.5), 1.0);
            assert!((below - 5.0).abs() < 1e-4, "y {y}: {below}");
            assert_eq!(
                grid.depth_from(Vec3::new(7.5, y as f32 + 0.5, 8.5), 1.0),
                0.0
            );
            assert_eq!(
                grid.depth_from(Vec3::new(8.5, y as f32 + 0.5, 9.5), 1.0),
                0.0
            );
        }
        for y in 5..32 {
            assert_eq!(
                grid.depth_from(Vec3::new(8.5, y as f32 + 0.5, 8.5), 1.0),
                0.0,
                "above, y {y}"
            );
        }
    }

    /// From outside, a ray reads the depth where it enters the grid; one that passes beside
    /// it or starts beyond it reads nothing: here a slab of 4 x 4 x 4 cells of 0.5 m, extinction
    /// 1 / m, lit along +x (and along a diagonal, whose zero components must not matter).
    #[test]
    fn rays_read_the_depth_where_they_enter_the_grid() {
        let mut level = Level::empty([4, 4, 4], 0.5);
        level.density[0] = vec![1.0; 64];
        let origin = Vec3::new(10.0, 0.0, 0.0);
        let grid = Grid::new(&level, origin, 1.0, 1.0, Vec3::X);
        let at = |x: f32, y: f32| grid.depth_from(Vec3::new(x, y, 1.0), 1.0);
        assert!((at(5.0, 1.0) - 2.0).abs() < 1e-5, "{}", at(5.0, 1.0));
        assert!((at(11.0, 1.0) - 1.0).abs() < 1e-5, "{}", at(11.0, 1.0));
        assert_eq!(at(5.0, 2.5), 0.0);
        assert_eq!(at(12.5, 1.0), 0.0);
        let diagonal = Grid::new(
            &level,
            origin,
            1.0,
            1.0,
            Vec3::new(1.0, 1.0, 0.0).normalize(),
        );
        let d = diagonal.depth_from(Vec3::new(10.0, 0.3, 1.0), 1.0);
        assert!((d - 3.4 * 0.5 * 2f32.sqrt()).abs() < 0.05, "{d}");
        assert_eq!(diagonal.depth_from(Vec3::new(10.0, 0.0, 2.5), 1.0), 0.0);
    }

    /// A sharp field (isolated dense cells, as a level 0's leaves are), read at random points
    /// inside it and through it from outside (a neighbour's shadow): the mean transmittance
    /// of the grid's lookups is a fine march's to 1.5 % (0.997-1.009), for suns along an
    /// axis, along a diagonal (columns a whole cell across per layer), in an axis plane and
    /// oblique. Read by interpolated depth, the same lookups are up to 6.3 % dark; by
    /// interpolated transmittance alone, with the sun along an axis, they were 7-20 % bright.
    #[test]
    fn a_sharp_field_lets_through_a_fine_marchs_light_on_average() {
        let mut by_depth_worst = 0.0f64;
        for (fill, density, cell) in [(0.1f32, 6.0f32, 0.25f64), (0.2, 4.0, 0.5)] {
            let mut level = Level::empty([24, 24, 24], cell);
            let mut s = Stream::new(5, 0);
            for d in level.density[1].iter_mut() {
                if (s.unit() as f32) < fill {
                    let u = s.unit() as f32;
                    *d = density * u * u;
                }
            }
            for sun in [
                Vec3::Y,
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(0.45, 0.89, 0.0),
                Vec3::new(0.3, 0.8, -0.5),
                Vec3::new(-0.58, 0.57, 0.58),
            ] {
                let sun = sun.normalize();
                let mut grid = Grid::new(&level, Vec3::ZERO, 1.0, 1.0, sun);
                let points: Vec<Vec3> = (0..3000)
                    .map(|i| {
                        let c = Vec3::new(s.unit() as f32, s.unit() as f32, s.unit() as f32);
                        // Every other point far on the shaded side: its ray crosses the grid.
                        c * 24.0 - sun * if i % 2 == 0 { 0.0 } else { 1000.0 }
                    })
                    .collect();
                let lit = |depth: &dyn Fn(Vec3) -> f32| -> f64 {
                    points.iter().map(|&c| f64::from((-depth(c)).exp())).sum()
                };
                let want = lit(&|c| marched(&level, 1.0, sun, c));
                let got = lit(&|c| grid.depth_from(c * cell as f32, 1.0)) / want;
                assert!(
                    (got - 1.0).abs() < 0.015,
                    "fill {fill}, sun {sun}: {got} of the marched light"
                );
                grid.blend = [0.0; 2];
                let by_depth = lit(&|c| grid.depth_from(c * cell as f32, 1.0)) / want;
                by_depth_worst = by_depth_worst.max((by_depth - 1.0).abs());
            }
        }
        assert!(
            by_depth_worst > 0.04,
            "{by_depth_worst}: the fields are not sharp"
        );
    }
}
