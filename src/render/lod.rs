//! Which representation draws each tree for one sample (`--method hybrid`): its texture where a
//! texture cell is no larger than the sample's footprint at the tree, its polygon model where
//! the cells would span pixels. The pure methods are the two ends: every tree a texture, or
//! every tree a mesh.
//!
//! The choice is made per instance and per sample, from the footprint at the instance's box
//! centre (not where a ray meets it), so the view ray and every shadow ray of one sample see
//! the same tree drawn the same way: a tree drawn as a mesh is never darkened by its own
//! texture, and a texture sample never by its own tree's triangles. Around the switch a band of
//! `band` octaves of footprint blends the two stochastically, the texture's probability rising
//! linearly in log footprint from 0 to 1 across the band, so a moving camera sees trees fade
//! from one representation to the other instead of popping, and the expected image in the
//! band is the blend of the two.
//!
//! Every sample of a frame has the same footprint and band key, so each tree's choice is the
//! frame's: `render` works them all out once (`Scene::choose`), and a ray looks them up.

use rayon::prelude::*;

use super::scene::Scene;
use crate::rng::{self, purpose};

/// Where the hybrid method switches representation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lod {
    /// The footprint, in texture cells of the tree's finest level, at which a tree is drawn
    /// as texture and mesh with equal probability.
    pub switch: f32,
    /// Width of the transition, in octaves (factors of two) of footprint; 0 switches hard.
    pub band: f32,
}

impl Default for Lod {
    fn default() -> Self {
        Lod {
            switch: 1.0,
            band: 1.0,
        }
    }
}

impl Lod {
    /// The switch for a pass of `spp` samples per pixel: as given up to 4, and from there
    /// times the square of spp / 4 (8 spp: 4 cells, 16: 16). With that many samples a pixel
    /// resolves the models' leaves, and a texture read at the samples' finer footprint is
    /// at its finest level, where its march costs most: in every view of `make report` the
    /// models were faster at equal error at 8 and 16 spp (README, *The hybrid above 4
    /// spp*), where at 4 the far view's textures still were.
    pub fn for_samples(self, spp: u32) -> Lod {
        let over = (spp as f32 / 4.0).max(1.0);
        Lod {
            switch: self.switch * over * over,
            ..self
        }
    }
}

/// How one sample draws the trees.
#[derive(Clone, Copy, Debug)]
pub enum Draw {
    /// Every tree from its texture (`--method texel`).
    Texel,
    /// Every tree from its polygon model (`--method mesh`).
    Mesh,
    /// Per tree, by footprint (`--method hybrid`).
    Hybrid {
        lod: Lod,
        /// The sample's footprint per metre of distance (radians).
        spread: f32,
        /// Keys the choice's draws, one per tree: the frame's (`RenderSettings::lod_seed`).
        key: u64,
        /// `lod`'s band ends ([`Lod::ends`]), worked out once per sample, not once per tree.
        ends: (f32, f32),
    },
}

impl Lod {
    /// The band's ends in texture cells per footprint: below the first a tree is always a
    /// mesh, above the second always a texture.
    fn ends(&self) -> (f32, f32) {
        let half = (0.5 * self.band).exp2();
        (self.switch / half, self.switch * half)
    }
}

impl Draw {
    /// The probability that instance `i` is drawn as texture for a footprint of `spread` per
    /// metre of distance.
    pub fn texel_probability(scene: &Scene, lod: &Lod, spread: f32, i: u32) -> f32 {
        Self::probability(scene, lod, lod.ends(), spread, i)
    }

    /// A sample's hybrid drawing, for a footprint of `spread` per metre of distance.
    pub fn hybrid(lod: Lod, spread: f32, key: u64) -> Draw {
        Draw::Hybrid {
            lod,
            spread,
            key,
            ends: lod.ends(),
        }
    }

    /// The same drawing, as cheaply as `scene` allows: where every tree lies beyond the model
    /// horizon (a far view), each is drawn from its texture whatever the sample, and the plain
    /// texture drawing makes those choices without working them out tree by tree: the same
    /// bytes, a few percent faster (README, *Measured*). Where the footprint is below every
    /// tree's band (many samples a pixel), each is drawn from its model, as the mesh method
    /// draws them.
    pub fn simplified(self, scene: &Scene) -> Draw {
        match self {
            Draw::Hybrid { .. }
                if self.model_horizon(scene) < scene.instances.nearest_distance() =>
            {
                Draw::Texel
            }
            // A tree is a model where its centre's distance x spread is at most lo x its
            // cell (`probability`); the margin covers rounding.
            Draw::Hybrid {
                spread,
                ends: (lo, _),
                ..
            } if spread < lo * scene.instances.finest_angle() * 0.999 => Draw::Mesh,
            _ => self,
        }
    }

    /// [`Draw::texel_probability`] with the band's ends given.
    #[inline]
    fn probability(scene: &Scene, lod: &Lod, (lo, hi): (f32, f32), spread: f32, i: u32) -> f32 {
        let (centre, cell) = scene.instances.centre_and_cell(i);
        // Most trees lie outside the band, which needs no logarithm (a hard switch is all
        // outside), nor a square root: the distance is compared squared with the band's ends.
        // 0 cells (the eye at the tree's centre) is the finest drawing, the model.
        let squared = centre.length_squared() * (spread * spread);
        if squared >= (hi * cell) * (hi * cell) {
            return 1.0;
        }
        if squared <= (lo * cell) * (lo * cell) {
            return 0.0;
        }
        let cells = centre.length() * spread / cell;
        ((cells / lod.switch).log2() / lod.band + 0.5).clamp(0.0, 1.0)
    }

    /// How far from the eye (the frame's origin) a ray of this sample can meet a tree drawn
    /// from its model: beyond it every tree is a texture, so a search for models' surfaces
    /// need not look there.
    pub fn model_horizon(&self, scene: &Scene) -> f32 {
        match *self {
            Draw::Texel => 0.0,
            Draw::Mesh => f32::INFINITY,
            Draw::Hybrid {
                spread,
                ends: (_, hi),
                ..
            } => {
                // A tree is a model only while its centre is nearer than hi x cell / spread
                // (`texel_probability`); its box reaches a radius further. The margin covers
                // rounding.
                let (cell, radius) = scene.instances.largest();
                let centre = hi * cell / spread;
                if centre.is_finite() {
                    (centre + radius) * 1.001 + 1e-3
                } else {
                    f32::INFINITY
                }
            }
        }
    }

    /// Whether instance `i` lies in the transition band for this sample: drawn from its
    /// texture or its model by chance, not by its footprint alone.
    #[inline]
    pub fn in_band(&self, scene: &Scene, i: u32) -> bool {
        match self.chosen(scene) {
            Some(c) => c.per_instance[i as usize] & IN_BAND != 0,
            None => self.in_band_by_footprint(scene, i),
        }
    }

    /// Whether instance `i` is drawn from its texture for this sample.
    #[inline]
    pub fn texel(&self, scene: &Scene, i: u32) -> bool {
        match self.chosen(scene) {
            Some(c) => c.per_instance[i as usize] & TEXTURE != 0,
            None => self.texel_by_footprint(scene, i),
        }
    }

    /// The scene's choices for the frame ([`Scene::choose`]), where this is the drawing they
    /// were worked out for.
    #[inline]
    fn chosen<'s>(&self, scene: &'s Scene) -> Option<&'s Choices> {
        let Draw::Hybrid {
            lod, spread, key, ..
        } = *self
        else {
            return None;
        };
        scene
            .choices
            .get()
            .filter(|c| c.lod == lod && c.spread == spread && c.key == key)
    }

    fn in_band_by_footprint(&self, scene: &Scene, i: u32) -> bool {
        match *self {
            Draw::Texel | Draw::Mesh => false,
            Draw::Hybrid {
                lod, spread, ends, ..
            } => {
                let p = Self::probability(scene, &lod, ends, spread, i);
                p > 0.0 && p < 1.0
            }
        }
    }

    fn texel_by_footprint(&self, scene: &Scene, i: u32) -> bool {
        match *self {
            Draw::Texel => true,
            Draw::Mesh => false,
            Draw::Hybrid {
                lod,
                spread,
                key,
                ends,
            } => {
                let p = Self::probability(scene, &lod, ends, spread, i);
                p >= 1.0
                    || (p > 0.0
                        && (rng::unit(rng::hash3(key, u64::from(i), purpose::LOD)) as f32) < p)
            }
        }
    }
}

/// [`Choices::per_instance`]' bits: drawn from the texture, and in the transition band.
const TEXTURE: u8 = 1;
const IN_BAND: u8 = 2;

/// How one hybrid drawing draws every tree of a frame. Every sample of a frame draws alike
/// (one footprint per sample, one key for the band's draws), so the choice of each tree is the
/// frame's: worked out once here, it is a byte's lookup for each of the many rays, view and
/// shadow, that meet the tree, where each worked it out again (6% of a one-thread near frame
/// at 480 x 270 in `perf`, with its logarithm).
pub struct Choices {
    lod: Lod,
    spread: f32,
    key: u64,
    /// Per instance, [`TEXTURE`] and [`IN_BAND`].
    per_instance: Vec<u8>,
}

impl Choices {
    /// `draw`'s choice for every tree of `scene`, if it chooses tree by tree (a hybrid
    /// drawing).
    pub(super) fn of(draw: &Draw, scene: &Scene) -> Option<Choices> {
        let Draw::Hybrid {
            lod, spread, key, ..
        } = *draw
        else {
            return None;
        };
        let per_instance = (0..scene.instances.len() as u32)
            .into_par_iter()
            .map(|i| {
                let texture = if draw.texel_by_footprint(scene, i) {
                    TEXTURE
                } else {
                    0
                };
                let band = if draw.in_band_by_footprint(scene, i) {
                    IN_BAND
                } else {
                    0
                };
                texture | band
            })
            .collect();
        Some(Choices {
            lod,
            spread,
            key,
            per_instance,
        })
    }
}
