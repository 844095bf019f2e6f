//! More samples where a picture has edges (`--edge-spp`): after the frame's first pass, each
//! pixel that differs from a neighbour by more than a contrast is rendered again with more
//! samples. At one sample per pixel most of the error lies there (README, *Measured*: in the
//! far view, 6.7% of the pixels hold 45% of the squared error): a silhouette against the sky
//! or the terrain covers part of a pixel, and one ray sees all of it or none. Inside a crown,
//! or on open ground, the texture's level has already smoothed the pixel, and more samples
//! would change it little.
//!
//! By default only the outline is sampled again ([`Edges::default_for`]); `--edge-spp` with
//! `--edge-contrast` looks at colour too.
//!
//! A pixel's choice depends on its neighbours' first pass only, which is keyed, like every
//! sample, by pixel: the frame is the same for any number of threads, and a crop equals that
//! part of the whole frame (its first pass reaches one pixel beyond it).

use super::Method;

/// Where and how a frame is sampled again.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Edges {
    /// Samples for a pixel at an edge, in place of the first pass's (whose work still counts).
    pub spp: u32,
    /// The least difference to a neighbour that makes an edge: in alpha, and where `colour`
    /// in a colour channel compared as c / (1 + c), so that light up to about 1 counts by its
    /// value and brighter light by its ratio, whatever the sun's strength.
    pub contrast: f32,
    /// Whether colour makes edges too (`--edge-contrast`), or alpha alone (the outline).
    pub colour: bool,
}

impl Edges {
    /// The outline: pixels whose alpha differs from a neighbour's by more than a half, where
    /// the terrain or a tree meets the sky, sampled again at 4 spp. No texture level smooths
    /// an outline, and at one sample per pixel it held a fifth of the far view's squared
    /// error; it is about 1% of that view's pixels (README, *The outline at one sample per
    /// pixel*).
    pub const OUTLINE: Edges = Edges {
        spp: 4,
        contrast: 0.5,
        colour: false,
    };

    /// What a frame of `method` at `spp` samples again unless told: the [`Edges::OUTLINE`]
    /// for the texel and hybrid methods at one sample per pixel, whose textures smooth
    /// everything but the outline. Nothing for the mesh method, the reference, whose every
    /// leaf is an edge; nor at more samples, where the pixel's own grid already covers the
    /// outline (the far view at 4 spp: 2% less error for 4% more time).
    pub fn default_for(method: Method, spp: u32) -> Option<Edges> {
        (method != Method::Mesh && spp == 1).then_some(Edges::OUTLINE)
    }

    /// Whether two pixels' first passes (premultiplied RGBA) differ by more than the contrast.
    pub fn differ(&self, a: [f32; 4], b: [f32; 4]) -> bool {
        let squash = |c: f32| c.max(0.0) / (1.0 + c.max(0.0));
        (a[3] - b[3]).abs() > self.contrast
            || self.colour && (0..3).any(|c| (squash(a[c]) - squash(b[c])).abs() > self.contrast)
    }

    /// Which pixels of `region` (x0, y0, x1, y1 exclusive) lie at an edge, row by row: each
    /// is compared with its four neighbours inside a `frame` of (width, height) pixels.
    /// `first(x, y)` is the first pass of any pixel of the frame within one of the region.
    pub fn find(
        &self,
        region: [u32; 4],
        frame: (u32, u32),
        first: impl Fn(u32, u32) -> [f32; 4],
    ) -> Vec<bool> {
        let [x0, y0, x1, y1] = region;
        let mut edges = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
        for y in y0..y1 {
            for x in x0..x1 {
                let here = first(x, y);
                let neighbours = [
                    (x > 0).then(|| (x - 1, y)),
                    (x + 1 < frame.0).then_some((x + 1, y)),
                    (y > 0).then(|| (x, y - 1)),
                    (y + 1 < frame.1).then_some((x, y + 1)),
                ];
                edges.push(
                    neighbours
                        .into_iter()
                        .flatten()
                        .any(|(u, v)| self.differ(here, first(u, v))),
                );
            }
        }
        edges
    }
}

/// The pixels of a `frame` just outside `region` (x0, y0, x1, y1 exclusive) that are a
/// region pixel's neighbour ([`Edges::find`]'s four): the ring one pixel wide around it,
/// without its corners, where it lies inside the frame. Row by row.
pub fn ring(region: [u32; 4], frame: (u32, u32)) -> Vec<(u32, u32)> {
    let [x0, y0, x1, y1] = region.map(i64::from);
    let (w, h) = (i64::from(frame.0), i64::from(frame.1));
    let mut ring = Vec::new();
    for y in (y0 - 1).max(0)..(y1 + 1).min(h) {
        for x in (x0 - 1).max(0)..(x1 + 1).min(w) {
            let (inside_x, inside_y) = ((x0..x1).contains(&x), (y0..y1).contains(&y));
            // Beside the region across one side, not across a corner.
            if inside_x != inside_y {
                ring.push((x as u32, y as u32));
            }
        }
    }
    ring
}

#[cfg(test)]
mod tests {
    use super::*;

    const EDGES: Edges = Edges {
        spp: 4,
        contrast: 0.05,
        colour: true,
    };

    #[test]
    fn a_step_marks_the_pixels_on_both_sides_and_no_others() {
        // A 6 x 3 frame, dark left of x = 3, bright from it.
        let first = |x: u32, _y: u32| {
            if x < 3 {
                [0.02, 0.03, 0.01, 1.0]
            } else {
                [0.8, 0.9, 1.2, 1.0]
            }
        };
        let edges = EDGES.find([0, 0, 6, 3], (6, 3), first);
        for y in 0..3 {
            let row: Vec<bool> = (0..6).map(|x| edges[y * 6 + x]).collect();
            assert_eq!(row, [false, false, true, true, false, false]);
        }
    }

    #[test]
    fn coverage_alone_makes_an_edge_and_small_differences_do_not() {
        assert!(EDGES.differ([0.1, 0.1, 0.1, 1.0], [0.1, 0.1, 0.1, 0.9]));
        assert!(!EDGES.differ([0.1, 0.1, 0.1, 1.0], [0.13, 0.12, 0.11, 0.98]));
        // Bright light counts by ratio: 10 against 11 is no edge, 1 against 2 is.
        assert!(!EDGES.differ([10.0, 10.0, 10.0, 1.0], [11.0, 11.0, 11.0, 1.0]));
        assert!(EDGES.differ([1.0, 1.0, 1.0, 1.0], [2.0, 2.0, 2.0, 1.0]));
    }

    /// The outline is where alpha changes by more than a half, whatever the colours do; and
    /// it is what the texel and hybrid methods sample again at one sample per pixel, unless
    /// told otherwise.
    #[test]
    fn the_outline_is_alpha_alone_and_the_default_at_one_sample() {
        let o = Edges::OUTLINE;
        assert!(o.differ([0.1, 0.1, 0.1, 1.0], [0.0, 0.0, 0.0, 0.0]));
        assert!(o.differ([0.1, 0.1, 0.1, 0.3], [0.1, 0.1, 0.1, 0.9]));
        assert!(!o.differ([0.1, 0.1, 0.1, 1.0], [0.1, 0.1, 0.1, 0.6]));
        assert!(!o.differ([0.02, 0.02, 0.02, 1.0], [5.0, 5.0, 5.0, 1.0]));
        for method in [Method::Texel, Method::Hybrid] {
            assert_eq!(Edges::default_for(method, 1), Some(o));
            assert_eq!(Edges::default_for(method, 4), None);
        }
        assert_eq!(Edges::default_for(Method::Mesh, 1), None);
    }

    #[test]
    fn a_crop_sees_the_edges_the_whole_frame_sees() {
        let first = |x: u32, y: u32| {
            let v = if (x * 7 + y * 3) % 5 < 2 { 0.9 } else { 0.1 };
            [v, v, v, 1.0]
        };
        let frame = (9, 7);
        let whole = EDGES.find([0, 0, 9, 7], frame, first);
        let crop = [2, 1, 6, 5];
        let part = EDGES.find(crop, frame, first);
        for y in 1..5 {
            for x in 2..6 {
                assert_eq!(part[(x - 2) + 4 * (y - 1)], whole[x + 9 * y], "({x}, {y})");
            }
        }
    }

    #[test]
    fn the_ring_is_the_regions_neighbours_inside_the_frame() {
        assert!(ring([0, 0, 5, 4], (5, 4)).is_empty());
        let r = ring([1, 1, 3, 2], (5, 4));
        assert_eq!(r, [(1, 0), (2, 0), (0, 1), (3, 1), (1, 2), (2, 2)]);
        // At the frame's corner the ring keeps to the frame.
        assert_eq!(ring([0, 0, 1, 1], (3, 3)), [(1, 0), (0, 1)]);
    }
}
