//! Coverage by object, for ID mattes (Cryptomatte): which tree, the terrain or the sky each
//! part of a pixel's alpha came from.
//!
//! A sample's ray records what it crosses as it goes, front to back: a texture segment's share
//! of the pixel (transmittance before it x its opacity) split among the trees containing it by
//! their extinction there, and what ends the ray (a tree's model, the terrain, an opaque sky)
//! by the transmittance left. The ray's Russian roulette and cut-off make those shares add up
//! to the sample's alpha only in expectation, so each sample's shares are scaled to add up to
//! its alpha exactly: the split among objects is the estimate, the total is the image's own
//! alpha. A pixel's coverages are the mean of its samples', so they add up to its alpha.
//!
//! Recording is per thread and off unless the pixel loop turns it on, so renders without
//! mattes pay one flag test per segment.

use std::cell::RefCell;

/// An object code: a tree's instance index, or one of these.
pub const TERRAIN: u32 = u32::MAX;
pub const SKY: u32 = u32::MAX - 1;

/// How many objects a pixel keeps, most coverage first: four EXR layers of two (id, coverage)
/// pairs each. Cryptomatte asks for at least six; the eighth tree behind a pixel of a far
/// view rarely holds more than a percent of it.
pub const RANKS: usize = 8;

/// A pixel's most-covering objects, most first; unused ranks have zero coverage.
pub type Ranks = [(u32, f32); RANKS];

struct Recorder {
    on: bool,
    /// The current sample's shares, by object (an object may appear more than once).
    parts: Vec<(u32, f32)>,
}

thread_local! {
    static RECORDER: RefCell<Recorder> = const {
        RefCell::new(Recorder { on: false, parts: Vec::new() })
    };
}

/// Starts a sample: recording on or off, nothing recorded.
pub(super) fn begin(on: bool) {
    RECORDER.with_borrow_mut(|r| {
        r.on = on;
        r.parts.clear();
    });
}

/// Whether this thread's sample is being recorded.
pub(super) fn recording() -> bool {
    RECORDER.with_borrow(|r| r.on)
}

/// `share` of the sample covered by `object`.
pub(super) fn add(object: u32, share: f32) {
    RECORDER.with_borrow_mut(|r| {
        if r.on && share > 0.0 {
            r.parts.push((object, share));
        }
    });
}

/// A segment's `share` split among the trees containing it by their extinctions there
/// (`each`: instance and extinction).
pub(super) fn add_split(each: &[(u32, f32)], share: f32) {
    let total: f32 = each.iter().map(|e| e.1).sum();
    if total <= 0.0 {
        return;
    }
    RECORDER.with_borrow_mut(|r| {
        if r.on {
            r.parts
                .extend(each.iter().map(|&(i, s)| (i, share * (s / total))));
        }
    });
}

/// A pixel's coverage by object, summed over its samples.
#[derive(Default)]
pub(super) struct Coverage {
    parts: Vec<(u32, f32)>,
}

impl Coverage {
    /// Adds the recorded sample, its shares scaled to add up to its `alpha`.
    pub(super) fn end_sample(&mut self, alpha: f32) {
        RECORDER.with_borrow_mut(|r| {
            let total: f32 = r.parts.iter().map(|p| p.1).sum();
            if total > 0.0 && alpha > 0.0 && total.is_finite() {
                let scale = alpha / total;
                for &(object, share) in &r.parts {
                    match self.parts.iter_mut().find(|p| p.0 == object) {
                        Some(p) => p.1 += share * scale,
                        None => self.parts.push((object, share * scale)),
                    }
                }
            }
            r.parts.clear();
        });
    }

    /// The pixel's ranks over `samples` samples, objects mapped by `group` (the identity for
    /// trees, a tree's species for species) and merged.
    pub(super) fn ranks(&self, samples: u32, group: impl Fn(u32) -> u32) -> Ranks {
        let mut merged: Vec<(u32, f32)> = Vec::with_capacity(self.parts.len());
        for &(object, c) in &self.parts {
            let g = group(object);
            match merged.iter_mut().find(|p| p.0 == g) {
                Some(p) => p.1 += c,
                None => merged.push((g, c)),
            }
        }
        // Most coverage first; equal coverage by object, so the order never depends on the
        // order rays met things.
        merged.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        let n = samples.max(1) as f32;
        let mut ranks = [(0, 0.0); RANKS];
        for (r, &(object, c)) in ranks.iter_mut().zip(&merged) {
            *r = (object, c / n);
        }
        ranks
    }
}

/// What Cryptomatte calls a scene's objects: a species by its name, a tree by its species and
/// its record's index in the `.instances` file (`conifer/1234`, the row of `texel export`),
/// the terrain `terrain` and an opaque sky `sky` (`terrain (ground)` and `sky (background)`
/// where a species has taken the plain name: a matte must tell them apart).
pub struct MatteNames {
    species: Vec<String>,
    /// Each tree's species.
    looks: Vec<u16>,
    terrain: String,
    sky: String,
}

impl MatteNames {
    /// The names of `scene`'s objects, its species named `species` in order.
    pub fn new(species: Vec<String>, scene: &super::Scene) -> MatteNames {
        let looks = (0..scene.instances.len() as u32)
            .map(|i| scene.instances.get(i).look)
            .collect();
        // The plain name, or the first of "terrain (ground)", "terrain (ground 2)", ... that
        // no species has taken.
        let free = |plain: &str, other: &str| {
            let taken = |name: &str| species.iter().any(|s| s == name);
            if !taken(plain) {
                return plain.to_string();
            }
            let mut name = format!("{plain} ({other})");
            let mut n = 1u64;
            while taken(&name) {
                n += 1;
                name = format!("{plain} ({other} {n})");
            }
            name
        };
        let (terrain, sky) = (free("terrain", "ground"), free("sky", "background"));
        MatteNames {
            species,
            looks,
            terrain,
            sky,
        }
    }

    /// The name of a species code (the terrain and the sky are their own species).
    pub fn species(&self, code: u32) -> &str {
        match code {
            TERRAIN => &self.terrain,
            SKY => &self.sky,
            s => self.species.get(s as usize).map_or("?", |s| s.as_str()),
        }
    }

    /// The name of an object code.
    pub fn tree(&self, code: u32) -> String {
        match code {
            TERRAIN | SKY => self.species(code).to_string(),
            i => {
                let look = self.looks.get(i as usize).copied().unwrap_or(u16::MAX);
                format!("{}/{i}", self.species(u32::from(look)))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_samples_shares_are_scaled_to_its_alpha_and_merged_by_object() {
        let mut c = Coverage::default();
        begin(true);
        add(3, 0.2);
        add_split(&[(3, 1.0), (5, 3.0)], 0.4);
        add(TERRAIN, 0.2);
        // Roulette carried the ray past a dense part: the shares add to 0.8, the alpha is 1.
        c.end_sample(1.0);
        begin(true);
        add(5, 0.5);
        c.end_sample(0.5);
        let ranks = c.ranks(2, |o| o);
        // Tree 5: (0.3 / 0.8 + 0.5) / 2; tree 3: 0.3 / 0.8 / 2; terrain 0.25 / 2.
        let expect = [(5, 0.4375), (3, 0.1875), (TERRAIN, 0.125)];
        for (r, e) in ranks.iter().zip(expect) {
            assert_eq!(r.0, e.0);
            assert!((r.1 - e.1).abs() < 1e-6, "{ranks:?}");
        }
        assert!(ranks[3..].iter().all(|r| r.1 == 0.0));
        let sum: f32 = ranks.iter().map(|r| r.1).sum();
        assert!((sum - 0.75).abs() < 1e-6, "the pixel's alpha");
    }

    #[test]
    fn grouping_merges_objects_and_off_records_nothing() {
        let mut c = Coverage::default();
        begin(false);
        add(1, 1.0);
        c.end_sample(1.0);
        assert!(c.ranks(1, |o| o).iter().all(|r| r.1 == 0.0));
        begin(true);
        add(1, 0.25);
        add(2, 0.25);
        add(7, 0.5);
        c.end_sample(1.0);
        // Trees 1 and 2 are one species (0), tree 7 another (1); tied coverage, lower first.
        let ranks = c.ranks(1, |o| u32::from(o == 7));
        assert_eq!(&ranks[..2], &[(0, 0.5), (1, 0.5)]);
    }
}
