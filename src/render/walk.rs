//! The front-to-back walk of a view ray through the instances, and how finely rays are
//! marched (`March`).
//!
//! Instances are found front to back and lazily, as interval events: a heap of bounding
//! volume nodes and instance boxes ordered by where the ray enters them; a node is opened only
//! when the march reaches it, so a grazing ray over a forest never collects the boxes it does
//! not reach. Between events the ray is cut into segments of one texture cell (at the level
//! the pixel's footprint needs); each segment takes one jittered sample (stratified Monte
//! Carlo), whose extinction, colour and normal stand for the segment: the segment transmits
//! exp(-sigma length) and adds T (1 - that) S.

use glam::Vec3;

use super::instances::{Intervals, TreeTransform};
use super::lod::Draw;
use super::scene::Scene;
use crate::geom::Ray;

/// How finely and how far rays are followed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct March {
    /// Segment length as a fraction of the texture cell (1 = one sample per cell).
    pub step: f32,
    /// Transmittance below which a ray stops (the paper's cut-off).
    pub cutoff: f32,
    /// Added to the mip level the footprint asks for, as a footprint 2^lod_bias times as wide
    /// asks (negative: sharper, slower).
    pub lod_bias: f32,
    /// Extra mip levels for shadow rays. 0 (the level the view ray reads) is the default:
    /// nearer the reference than 1 in every view of `make report`, and no slower (README,
    /// *Measured*).
    pub shadow_lod: f32,
    /// Russian roulette on shadow rays: a sample whose share of its ray (transmittance x
    /// opacity; of the pixel at 1 spp) is below this casts its shadow ray with probability
    /// share / this, and counts it that many times more. Unbiased; 0 casts every shadow ray.
    /// The default, 0.2, is the fastest at equal error in every view of `make report` (README,
    /// *Measured*).
    pub shadow_share: f32,
    /// How shadow rays cross the trees' textures. Exact by default here, the estimator the
    /// library's tests hold to analytic answers; `texel render` defaults to cached.
    pub shadows: ShadowRays,
    /// Russian roulette on view rays: once the transmittance falls below this, a ray goes on
    /// past each segment with probability transmittance / this, carrying this. Unbiased; 0
    /// marches every ray to the cut-off.
    pub view_share: f32,
}

impl Default for March {
    fn default() -> Self {
        March {
            step: 1.0,
            cutoff: 1e-3,
            lod_bias: 0.0,
            shadow_lod: 0.0,
            shadow_share: 0.2,
            shadows: ShadowRays::Exact,
            view_share: 0.05,
        }
    }
}

/// How a shadow ray finds its optical depth through the trees' textures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadowRays {
    /// One lookup per tree in its grid of depths towards the sun (`render::sun_depth`); the
    /// tree the sample lies in marched for its first few cells, then looked up.
    Cached,
    /// A jittered march through every tree, as a view ray marches: unbiased, for references.
    Exact,
}

/// The mip level of instance `i` whose cells match a footprint of `footprint` metres, moved
/// by `lod_bias` levels.
pub(super) fn level_for(scene: &Scene, i: u32, footprint: f32, lod_bias: f32) -> usize {
    let inst: &TreeTransform = scene.instances.get(i);
    let cell0 = scene.instances.finest_cell(inst.model);
    let levels = scene.texels[inst.model as usize].levels.len();
    level_of(footprint / inst.scale / cell0, lod_bias, levels)
}

/// The level of `levels` whose cells match a footprint of `cells` finest cells, moved by
/// `lod_bias` levels, as a footprint 2^lod_bias times as wide: the whole part of
/// log2(cells) + lod_bias, clamped to the levels there are. So a bias of 2 at 16 spp reads
/// what one sample per pixel reads, for trees nearer than a finest cell a pixel too (adding 2
/// to the level a footprint below a cell is clamped to would read them coarser).
fn level_of(cells: f32, lod_bias: f32, levels: usize) -> usize {
    // No footprint at all reads as one cell (the bias's own level); none, with the eye at
    // the tree's centre, as the finest. With a whole bias (the defaults) only log2's whole
    // part counts, and for a positive normal float that is its exponent (a subnormal's reads
    // -127, far below any level): a shadow ray asks for a level for every tree it passes, and
    // this function with its logarithm was a twentieth of a far frame.
    let log2 = if cells.is_nan() {
        0.0
    } else if cells <= 0.0 {
        f32::NEG_INFINITY
    } else if floor(lod_bias) == lod_bias {
        ((cells.to_bits() >> 23) as i32 - 127) as f32
    } else {
        cells.log2()
    };
    ((log2 + lod_bias).max(0.0) as usize).min(levels - 1)
}

/// `x.floor()`, bit for bit, without a call into libm where it is cheap to avoid (baseline
/// x86-64 has no rounding instruction): the marches count the whole segments an empty stretch
/// holds with it.
#[inline]
pub(super) fn floor(x: f32) -> f32 {
    // Below 2^23 a positive float may have a fraction, and the cast drops it; from there on
    // it is whole. The rest (zeros, whose sign floor keeps, negatives, not finite) goes to libm.
    if x > 0.0 && x < 8_388_608.0 {
        (x as u32) as f32
    } else {
        x.floor()
    }
}

/// An instance the ray is inside of, with its ray in the texture's cell coordinates.
#[derive(Clone, Copy)]
pub(super) struct Active {
    pub(super) instance: u32,
    /// Index into the scene's texels.
    pub(super) model: u32,
    pub(super) exit: f32,
    pub(super) level: usize,
    /// Cell coordinates at t = 0 and per unit t.
    pub(super) c0: Vec3,
    pub(super) dc: Vec3,
    /// Extinction per density, 1/m of the renderer's frame, at most [`SIGMA_MAX`].
    pub(super) sigma_scale: f32,
    /// Segment length in this texture (m).
    pub(super) step: f32,
    /// Factors on the wood's and the foliage's extinction where this ray is a view ray
    /// (`volume::PartFacing`, [`Active::seen`]; 1 on shadow rays): constant along it, as the
    /// directional factor is.
    pub(super) facing: [f32; 2],
    /// Whether the ray's brick of this texture (`volume::Occupancy`) can hold density, and
    /// until where along the ray that holds (`-inf`: not looked at yet).
    pub(super) span: (bool, f32),
}

/// The largest extinction (1/m) the renderer holds. A file may ask for more (its scale is
/// f64, its densities reach f32's limit) and all of it is opaque over any step the renderer
/// takes (a nanometre has an optical depth of 1e9), so more is kept as this much: sums over
/// overlapping boxes and products with albedos stay finite, and a zero weight on it stays 0
/// where infinity would make NaN and the film would draw the pixel black.
pub(super) const SIGMA_MAX: f32 = 1e18;

impl Active {
    /// The extinction (1/m) of `density` in this texture, at most [`SIGMA_MAX`] (a density of
    /// 0 is 0).
    pub(super) fn extinction(&self, density: f32) -> f32 {
        (self.sigma_scale * density).min(SIGMA_MAX)
    }

    /// Instance `i` as a ray meets it (`local`: the ray in its model space, leaving at `exit`),
    /// where the ray's footprint is `footprint` metres: the mip level whose cells match it, and
    /// the ray in that level's cells.
    pub(super) fn new(
        scene: &Scene,
        i: u32,
        local: &Ray,
        exit: f32,
        footprint: f32,
        lod_bias: f32,
    ) -> Active {
        Active::at_level(
            scene,
            i,
            local,
            exit,
            level_for(scene, i, footprint, lod_bias),
        )
    }

    /// Instance `i` as a ray meets it (`local`, in its model space), read at mip level `level`.
    pub(super) fn at_level(scene: &Scene, i: u32, local: &Ray, exit: f32, level: usize) -> Active {
        let inst: &TreeTransform = scene.instances.get(i);
        let texel = scene.texel_of(i);
        let cell = texel.levels[level].cell as f32;
        let origin = texel.origin().as_vec3();
        let dir = local.dir;
        // Extinction depends on direction only through the level's factors, constant along
        // a straight ray: one multiplier per instance the ray meets.
        let directional = texel.levels[level].directional_factor(dir);
        Active {
            instance: i,
            model: inst.model,
            exit,
            level,
            c0: (local.origin - origin) / cell,
            dc: dir / cell,
            // A valid file's scale may lie beyond f32's range: capped first, it stays finite
            // through the factor (at most 4096 or so) and the instance's scale (2^-16 or more).
            sigma_scale: (texel.info.extinction_scale.min(f64::from(SIGMA_MAX)) as f32
                * directional
                / inst.scale)
                .min(SIGMA_MAX),
            step: cell * inst.scale,
            facing: [1.0; 2],
            span: (true, f32::NEG_INFINITY),
        }
    }

    /// This instance on a view ray along `dir` (model space): each part's extinction as much
    /// as faces the eye.
    pub(super) fn seen(self, scene: &Scene, dir: Vec3) -> Active {
        let facing = scene.occupancy[self.model as usize][self.level]
            .part_facing
            .along(dir);
        Active { facing, ..self }
    }

    /// Where this texture can next hold density along the ray from `t`, if the ray is in an
    /// empty brick at `t`; `None` where it may hold some.
    pub(super) fn empty_until(&mut self, scene: &Scene, t: f32) -> Option<f32> {
        if t >= self.span.1 {
            let occupancy = &scene.occupancy[self.model as usize][self.level];
            self.span = occupancy.span(self.c0, self.dc, t, self.exit);
        }
        (!self.span.0).then_some(self.span.1)
    }

    /// Whether the walk has already found this texture's brick empty at `t` (at or after the
    /// point `empty_until` last looked from): a sample there reads nothing of it, and need not
    /// look at its cells' bits.
    #[inline]
    pub(super) fn found_empty_at(&self, t: f32) -> bool {
        !self.span.0 && t < self.span.1
    }
}

/// The front-to-back walk of the instances along one ray: which are active (the ray is inside
/// their box) at each point, and the mip level each is read at. Only the trees its sample
/// draws from their textures are ever active.
pub(super) struct Walk<'a> {
    pub(super) scene: &'a Scene,
    pub(super) ray: Ray,
    pub(super) intervals: Intervals<'a>,
    pub(super) active: Vec<Active>,
    /// Cone: footprint (m) at distance t is t x spread.
    pub(super) spread: f32,
    pub(super) lod_bias: f32,
    pub(super) draw: Draw,
    /// Where the walk ends: the terrain, or the nearest surface of a tree drawn as a model.
    pub(super) t_max: f32,
}

impl<'a> Walk<'a> {
    pub(super) fn new(
        scene: &'a Scene,
        ray: Ray,
        t_max: f32,
        spread: f32,
        lod_bias: f32,
        draw: Draw,
    ) -> Walk<'a> {
        Walk {
            scene,
            ray,
            intervals: scene.instances.intervals(ray, t_max),
            active: Vec::new(),
            spread,
            lod_bias,
            draw,
            t_max,
        }
    }

    /// Where the next instance or node begins, if any.
    pub(super) fn next_entry(&self) -> Option<f32> {
        self.intervals.next_entry()
    }

    /// Activates every instance the ray has entered by `t`.
    pub(super) fn admit(&mut self, t: f32) {
        while let Some((i, enter, exit)) = self.intervals.next_entered(t) {
            if !self.draw.texel(self.scene, i) {
                continue;
            }
            let footprint = enter * self.spread;
            let local = self.scene.instances.get(i).local_ray(&self.ray);
            let a = Active::new(self.scene, i, &local, exit, footprint, self.lod_bias)
                .seen(self.scene, local.dir);
            self.active.push(a);
        }
    }

    pub(super) fn retire(&mut self, t: f32) {
        self.active.retain(|a| a.exit > t);
    }

    /// Where the ray may next meet density, if every active texture is empty at `t` (and no
    /// instance begins before): the march jumps there, skipping only what is exactly empty.
    pub(super) fn empty_until(&mut self, t: f32) -> Option<f32> {
        let mut until = self.next_entry().unwrap_or(f32::INFINITY);
        for a in &mut self.active {
            until = until.min(a.empty_until(self.scene, t)?);
        }
        (until > t).then_some(until)
    }

    /// Brings the walk to `t` and returns where the next segment starts: `t` itself while
    /// the ray is inside some instance, else the next instance's entry; `None` past `t_max`.
    pub(super) fn advance(&mut self, mut t: f32) -> Option<f32> {
        loop {
            self.admit(t);
            self.retire(t);
            if !self.active.is_empty() {
                return Some(t);
            }
            t = self.next_entry().filter(|&e| e < self.t_max)?;
        }
    }
}

/// The end of the segment starting at `t` (one step of the finest active texture, cut at the
/// next event) and the sample position inside it, a fraction `u` of the way along.
pub(super) fn segment_end(walk: &Walk, t: f32, t_max: f32, step: f32, u: f64) -> (f32, f32) {
    let mut end = t_max;
    for a in &walk.active {
        end = end.min(t + a.step * step).min(a.exit);
    }
    if let Some(e) = walk.next_entry() {
        end = end.min(e.max(t));
    }
    // A zero-length segment cannot advance: guarantee progress by a hair.
    if end <= t {
        end = t + f32::EPSILON * t.max(1.0);
    }
    (end, t + u as f32 * (end - t))
}

#[cfg(test)]
mod tests {
    use super::level_of;
    use crate::rng::Stream;

    /// [`super::floor`] is `f32::floor` for every float around the cut at 2^23, the whole
    /// numbers, and a spread of others (negative, tiny, huge, not finite).
    #[test]
    fn floor_is_libms() {
        let mut s = Stream::new(4, 0);
        let mut xs: Vec<f32> = vec![0.0, -0.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN];
        for k in -2000i32..2000 {
            let cut = 8_388_608.0f32;
            xs.push(f32::from_bits((cut.to_bits() as i32 + k) as u32));
            xs.push(k as f32);
            xs.push(k as f32 / 7.0);
        }
        xs.extend(
            (0..20000)
                .map(|_| ((s.unit() - 0.5) * 80.0).exp2() as f32 * (s.unit() * 2.0 - 1.0) as f32),
        );
        for x in xs {
            assert_eq!(super::floor(x).to_bits(), x.floor().to_bits(), "{x}");
        }
    }

    /// The level is the whole part of log2(cells) + bias, clamped to the levels there are, as
    /// f64 works it out, for whole biases (read from the exponent) and others (a logarithm),
    /// footprints below a finest cell included; no footprint, not a number or infinite read
    /// the finest, the bias's own and the coarsest.
    #[test]
    fn a_footprint_reads_the_level_whose_cells_match_it() {
        let mut s = Stream::new(3, 0);
        for _ in 0..20000 {
            let cells = (s.unit() * 30.0 - 6.0).exp2() as f32;
            for bias in [-2.0f32, -1.0, 0.0, 1.0, 3.0, -0.5, 0.25, 1.75] {
                let want = (f64::from(cells).log2() + f64::from(bias))
                    .floor()
                    .clamp(0.0, 6.0);
                assert_eq!(
                    level_of(cells, bias, 7),
                    want as usize,
                    "{cells} cells, bias {bias}"
                );
            }
        }
        for k in 0..24 {
            let cells = (k as f32).exp2();
            assert_eq!(level_of(cells, 0.0, 30), k);
            assert_eq!(level_of(cells.next_down(), 0.0, 30), k.saturating_sub(1));
        }
        assert_eq!(level_of(0.3, 0.0, 5), 0);
        // A sixteenth of a pixel's footprint two levels up reads what the pixel's does.
        assert_eq!(level_of(0.3, 2.0, 5), level_of(1.2, 0.0, 5));
        assert_eq!(level_of(0.5, 2.0, 5), 1);
        assert_eq!(level_of(0.0, 2.0, 5), 0);
        assert_eq!(level_of(-0.0, 2.0, 5), 0);
        assert_eq!(level_of(f32::NAN, 1.0, 5), 1);
        assert_eq!(level_of(f32::INFINITY, 0.0, 5), 4);
    }
}
