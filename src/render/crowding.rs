//! How many trees stand over one spot of a forest. A ray's work grows with the trees whose
//! boxes it is inside at once: it enters them all where it enters the first, before any is
//! dense enough to stop it. `place` keeps every tree its spacing from the next, so a point of
//! its forests lies under a few trees; but a hand-made `.instances` file of a few kilobytes
//! can stand a million trees on one spot, and a 64 x 36 render of it took over a minute. So
//! the renderer counts, before it builds anything, the trees over each tree's base, and
//! refuses a forest where one count is over the limit (`--max-overlap`).
//!
//! A tree stands over a point when the point lies within its reach: the largest horizontal
//! distance from its base (the model's origin, which it turns about) to a corner of the box the
//! renderer gives it (its texture's grid, all levels), times its scale. Heights are left out, so trees piled one above another count as one pile.

use rayon::prelude::*;

/// The first tree whose base more than `limit` trees stand over (itself included), and how
/// many do; `None` where every base has at most `limit`. `trees` are each tree's base (x, z)
/// and reach, in metres from the forest's origin.
///
/// The trees' discs (base and reach) are grouped by reach, an octave per group, and each group
/// is held in a hierarchy of boxes (each node the box of the discs below it). A base visits
/// the nodes whose boxes hold it: in a group of like sizes, about the discs that stand over it
/// and their near neighbours, whatever the other groups hold (a few giants among a million
/// small trees cost each base a few steps, not a walk through every box the giants widen). A
/// base's count stops at `limit + 1`, so a pile is refused at its first base.
pub fn most_crowded(trees: &[([f64; 2], f64)], limit: u64) -> Option<(usize, u64)> {
    let mut groups: Vec<Vec<u32>> = vec![Vec::new(); GROUPS];
    for (i, &(_, reach)) in trees.iter().enumerate() {
        groups[group(reach)].push(i as u32);
    }
    let groups: Vec<Discs> = groups
        .into_iter()
        .filter(|g| !g.is_empty())
        .map(|g| Discs::new(trees, g))
        .collect();
    let over = |i: usize, most: u64| {
        let mut n = 0;
        for g in &groups {
            n += g.over(trees, trees[i].0, most - n);
            if n >= most {
                break;
            }
        }
        n
    };
    let first = (0..trees.len())
        .into_par_iter()
        .position_first(|i| over(i, limit.saturating_add(1)) > limit)?;
    Some((first, over(first, u64::MAX)))
}

/// Groups of reach: below 2^-8 m, each octave up to 2^31 m, and above (a forest's trees lie
/// within 2^31 cm of its origin, so such a tree stands over every one).
const GROUPS: usize = 41;

fn group(reach: f64) -> usize {
    if reach > 0.0 {
        (reach.log2().floor() + 9.0).clamp(0.0, (GROUPS - 1) as f64) as usize
    } else {
        0
    }
}

/// Whether a tree at `centre` of `reach` stands over `point`. Most are told by a side alone;
/// hypot, not a sum of squares, where squares of large distances would overflow.
fn reaches(centre: [f64; 2], reach: f64, point: [f64; 2]) -> bool {
    let (dx, dz) = ((centre[0] - point[0]).abs(), (centre[1] - point[1]).abs());
    dx <= reach && dz <= reach && dx.hypot(dz) <= reach
}

/// Discs in a hierarchy of boxes, split at the median base along x and z in turn.
struct Discs {
    nodes: Vec<Node>,
    /// The trees, in the order of the leaves.
    order: Vec<u32>,
}

/// A box (x0, z0, x1, z1) holding the discs of `order[lo..hi]`.
struct Node {
    bounds: [f64; 4],
    lo: u32,
    hi: u32,
    /// The index of the first child (the second follows it); 0 for a leaf.
    children: u32,
}

/// At most this many discs are scanned in a leaf.
const LEAF: usize = 8;

impl Discs {
    /// The hierarchy of the discs of `trees` numbered in `order`.
    fn new(trees: &[([f64; 2], f64)], order: Vec<u32>) -> Discs {
        let mut discs = Discs {
            nodes: Vec::with_capacity(2 * order.len() / LEAF + 1),
            order,
        };
        discs.nodes.push(Node {
            bounds: [0.0; 4],
            lo: 0,
            hi: discs.order.len() as u32,
            children: 0,
        });
        discs.build(0, trees, 0);
        discs
    }

    /// Splits node `n` (splitting on `axis`) and its subtrees, and sets their boxes.
    fn build(&mut self, n: usize, trees: &[([f64; 2], f64)], axis: usize) {
        let (lo, hi) = (self.nodes[n].lo as usize, self.nodes[n].hi as usize);
        if hi - lo <= LEAF {
            let mut b = [
                f64::INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NEG_INFINITY,
            ];
            for &i in &self.order[lo..hi] {
                let ([x, z], r) = trees[i as usize];
                b = [
                    b[0].min(x - r),
                    b[1].min(z - r),
                    b[2].max(x + r),
                    b[3].max(z + r),
                ];
            }
            self.nodes[n].bounds = b;
            return;
        }
        let mid = (lo + hi) / 2;
        self.order[lo..hi].select_nth_unstable_by(mid - lo, |&a, &b| {
            trees[a as usize].0[axis].total_cmp(&trees[b as usize].0[axis])
        });
        let first = self.nodes.len();
        self.nodes[n].children = first as u32;
        for (a, b) in [(lo, mid), (mid, hi)] {
            self.nodes.push(Node {
                bounds: [0.0; 4],
                lo: a as u32,
                hi: b as u32,
                children: 0,
            });
        }
        self.build(first, trees, 1 - axis);
        self.build(first + 1, trees, 1 - axis);
        let ([a0, a1, a2, a3], [b0, b1, b2, b3]) =
            (self.nodes[first].bounds, self.nodes[first + 1].bounds);
        self.nodes[n].bounds = [a0.min(b0), a1.min(b1), a2.max(b2), a3.max(b3)];
    }

    /// How many discs hold `point`, counted up to `most`.
    fn over(&self, trees: &[([f64; 2], f64)], point: [f64; 2], most: u64) -> u64 {
        let mut n = 0;
        // Each node visited puts at most its two children on it: at most one more entry per
        // level of the hierarchy, which halves the discs from level to level (at most 2^32).
        let mut stack = [0u32; 64];
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            let node = &self.nodes[stack[depth] as usize];
            let [x0, z0, x1, z1] = node.bounds;
            if !(x0 <= point[0] && point[0] <= x1 && z0 <= point[1] && point[1] <= z1) {
                continue;
            }
            if node.children == 0 {
                for &i in &self.order[node.lo as usize..node.hi as usize] {
                    let (centre, reach) = trees[i as usize];
                    if reaches(centre, reach, point) {
                        n += 1;
                        if n >= most {
                            return n;
                        }
                    }
                }
            } else {
                stack[depth] = node.children;
                stack[depth + 1] = node.children + 1;
                depth += 2;
            }
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use super::most_crowded;

    #[test]
    fn a_pile_is_found_and_counted_and_a_spaced_forest_passes() {
        // A grid of trees 5 m apart, each reaching 6 m: a base lies within reach of itself
        // and its four nearest neighbours (5 m), not the diagonal ones (7.1 m).
        let mut trees: Vec<([f64; 2], f64)> = (0..400)
            .map(|i| ([f64::from(i % 20) * 5.0, f64::from(i / 20) * 5.0], 6.0))
            .collect();
        assert_eq!(most_crowded(&trees, 5), None);
        // A corner tree has two neighbours, an edge tree three: the first inside is 21.
        assert_eq!(most_crowded(&trees, 4), Some((21, 5)));
        // A pile of 3,000 trees on one base, and one giant whose reach covers everything.
        trees.extend(std::iter::repeat_n(([50.0, 50.0], 1.0), 3000));
        trees.push(([-1e6, 0.0], 2e6));
        let (i, n) = most_crowded(&trees, 1024).unwrap();
        assert_eq!(trees[i].0, [50.0, 50.0]);
        // The pile, the giant, and the grid tree standing on the same spot with its four
        // neighbours.
        assert_eq!(n, 3000 + 1 + 5);
    }

    #[test]
    fn reaches_of_every_size_and_far_places_are_counted_without_overflow() {
        let trees = [
            ([0.0, 0.0], 0.0),
            ([0.0, 0.0], 1e-300),
            ([1e300, -1e300], 1e300),
            ([-1e300, 1e300], 3.0),
            ([0.5, 0.0], 0.5),
        ];
        // The first two stand on one spot, and the fifth reaches it.
        assert_eq!(most_crowded(&trees, 2), Some((0, 3)));
        assert_eq!(most_crowded(&trees, 3), None);
    }

    /// Against counting every pair, on trees of sizes 10^-3 to 10^3 times each other, some
    /// piled: the same first tree and count at every limit.
    #[test]
    fn counts_are_those_of_every_pair() {
        let trees: Vec<([f64; 2], f64)> = (0..600u64)
            .map(|i| {
                let u = |k| crate::rng::unit(crate::rng::hash3(7, i, k));
                let at = if i % 7 == 0 {
                    [3.0, 4.0]
                } else {
                    [u(0) * 100.0, u(1) * 100.0]
                };
                (at, 10f64.powf(u(2) * 6.0 - 3.0))
            })
            .collect();
        let counts: Vec<u64> = trees
            .iter()
            .map(|&(p, _)| {
                trees
                    .iter()
                    .filter(|&&(c, r)| super::reaches(c, r, p))
                    .count() as u64
            })
            .collect();
        for limit in [1, 2, 5, 20, 50, 90, 200, 1000] {
            let expected = counts
                .iter()
                .position(|&n| n > limit)
                .map(|i| (i, counts[i]));
            let found = most_crowded(&trees, limit);
            // Counting stops at the first tree that pushes some base over: the base it
            // reports is over the limit, with its whole count, and none is missed.
            match (expected, found) {
                (None, None) => {}
                (Some(_), Some((i, n))) => {
                    assert!(n > limit && counts[i] == n, "limit {limit}: {i} {n}");
                }
                other => panic!("limit {limit}: {other:?}"),
            }
        }
    }
}
