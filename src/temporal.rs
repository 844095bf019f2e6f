//! Flicker of a frame sequence: how much each pixel changes from one frame to the next once the
//! camera's motion is undone, the measure behind `texel compare --temporal`.
//!
//! For each pair of consecutive frames (n, n + 1), every pixel of frame n inside the mask that
//! shows a surface (a finite `Z`) is carried into frame n + 1: its world point is recovered from
//! its depth and frame n's `worldToCamera` and `worldToNDC`, projected with frame n + 1's, and
//! frame n + 1 is sampled there bilinearly. Its change is that sample minus the pixel, for each
//! of R, G and B as stored (premultiplied, linear). A pixel is rejected, not measured, where its
//! point leaves frame n + 1, where frame n + 1 shows another surface there (hidden or uncovered:
//! the depths disagree), or where it shows no surface (the sky) and the camera moved. Two frames
//! with the same matrices are compared pixel for pixel, sky included: the reprojection is the
//! identity, and this is the baseline of a static camera whose samples are jittered.

use std::path::{Path, PathBuf};

use glam::{DMat4, DVec3, DVec4};
use serde::Serialize;

use crate::compare::{CompareError, ExrLayer, Rgba, check_same_window};
use crate::limits::Limits;

/// How far (a fraction of the reprojected depth) frame n + 1's depth may be from where frame
/// n's point lands and still be the same surface. The bilinear sample reads pixels up to one
/// pixel away, whose depth on a tilted surface differs by (depth x pixel angle x the tangent of
/// the tilt): within 5% for a surface up to 88 degrees from facing the camera at 1080 lines and
/// 60 degrees of view. A canopy's `Z` (where its opacity reaches half its final value, nearest
/// over the pixel's samples) moves with the samples; on the fixture forest 1.6% of the canopy's
/// pixels are rejected at 5% (8.7% at 2%, 0.4% at 10%; README, `texel compare`). Yet a tree
/// 5 m behind another at 100 m is still told apart.
pub const DEFAULT_DEPTH_TOLERANCE: f64 = 0.05;

/// Reprojections this close (in pixels) to a pixel centre read that pixel alone. A point that
/// should land on a centre (a camera moved by whole pixels) is computed within rounding error of
/// it, on either side (1e-15 of a pixel in the tests); the bilinear footprint would then reach a
/// neighbour with a vanishing weight, and reject the point if that neighbour lies outside the
/// frame or on another surface, for nothing the sample could show.
const SNAP: f64 = 1e-6;

/// Bytes a pixel of a [`Frame`] holds (R, G, B, A, Z and the mask), two frames at a time.
const HELD_BYTES: u64 = 2 * (16 + 4 + 1);

#[derive(Debug, thiserror::Error)]
pub enum TemporalError {
    #[error(transparent)]
    Read(#[from] CompareError),
    #[error(
        "{file}: has no {attribute} attribute: a frame's camera matrices are needed to undo the \
         camera's motion (texel render writes them)"
    )]
    NoMatrix {
        file: PathBuf,
        attribute: &'static str,
    },
    #[error("{file}: its {attribute} matrix {problem}")]
    BadMatrix {
        file: PathBuf,
        attribute: &'static str,
        problem: &'static str,
    },
    #[error("a temporal comparison needs at least two frames, got {0}")]
    TooFewFrames(usize),
    #[error("the depth tolerance {0} is not a finite fraction of at least 0")]
    Tolerance(f64),
    #[error("{0}: its colour, depth and mask do not all cover its window")]
    Inconsistent(PathBuf),
}

/// Where a frame's camera was: the OpenEXR matrices (for row vectors, as Imath stores them)
/// and the display window that NDC (0, 0)-(1, 1) spans.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    pub world_to_camera: [f32; 16],
    pub world_to_ndc: [f32; 16],
    /// Top-left corner and size of the display window, in pixels.
    pub display_origin: [i32; 2],
    pub display_size: [usize; 2],
}

/// One frame of a sequence.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// The file it was read from (named in errors).
    pub path: PathBuf,
    pub rgba: Rgba,
    /// Camera-space depth of each pixel's surface; not finite where there is none (the sky).
    pub z: Vec<f32>,
    /// Which pixels (by index) are measured when this frame is the earlier of a pair; `None`
    /// measures them all.
    pub inside: Option<Vec<bool>>,
    pub view: View,
}

/// Which pixels of a frame are measured: those where channel `inside` is above one half
/// (every pixel without one), less those where channel `outside` is.
#[derive(Clone, Copy, Debug, Default)]
pub struct Mask<'a> {
    pub inside: Option<&'a str>,
    pub outside: Option<&'a str>,
}

impl<'a> Mask<'a> {
    /// Every pixel.
    pub const ALL: Mask<'static> = Mask {
        inside: None,
        outside: None,
    };

    /// The pixels where `channel` is above one half.
    pub fn inside(channel: &'a str) -> Mask<'a> {
        Mask {
            inside: Some(channel),
            outside: None,
        }
    }
}

impl Frame {
    /// Reads R, G, B, A, Z, the camera's matrices and, if asked, the mask's channels.
    pub fn read(path: &Path, mask: Mask, limits: &Limits) -> Result<Frame, TemporalError> {
        let layer = ExrLayer::read(path, limits, HELD_BYTES)?;
        let rgba = layer.rgba(crate::compare::CHANNELS)?;
        let z = layer.channel("Z")?.collect();
        let mut inside: Option<Vec<bool>> = match mask.inside {
            Some(name) => Some(layer.channel(name)?.map(|v| v > 0.5).collect()),
            None => None,
        };
        if let Some(name) = mask.outside {
            let outside: Vec<bool> = layer.channel(name)?.map(|v| v > 0.5).collect();
            inside = Some(match inside {
                Some(i) => i.iter().zip(&outside).map(|(&a, &b)| a && !b).collect(),
                None => outside.iter().map(|&b| !b).collect(),
            });
        }
        let missing = |attribute| TemporalError::NoMatrix {
            file: path.to_path_buf(),
            attribute,
        };
        let (world_to_camera, world_to_ndc) = layer.camera_matrices();
        let (display_origin, display_size) = layer.display_window();
        Ok(Frame {
            path: path.to_path_buf(),
            rgba,
            z,
            inside,
            view: View {
                world_to_camera: world_to_camera.ok_or_else(|| missing("worldToCamera"))?,
                world_to_ndc: world_to_ndc.ok_or_else(|| missing("worldToNDC"))?,
                display_origin,
                display_size,
            },
        })
    }
}

/// Pixels of the earlier frame inside the mask that were not measured, by why.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Rejected {
    /// No surface to follow (a depth that is not finite: the sky) while the camera moved.
    pub no_depth: usize,
    /// The point lands outside the later frame (or behind its camera).
    pub outside_frame: usize,
    /// The later frame shows another surface where the point lands: a pixel its bilinear
    /// sample reads has no depth or one beyond the tolerance (hidden, or uncovered).
    pub depth_mismatch: usize,
    /// A colour the change would be taken from is NaN or infinite.
    pub non_finite: usize,
}

impl Rejected {
    pub fn total(&self) -> usize {
        self.no_depth + self.outside_frame + self.depth_mismatch + self.non_finite
    }
}

/// The change from one frame to the next over the pixels measured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Change {
    /// Pixels of the earlier frame inside the mask (all of them without one).
    pub inside_mask: usize,
    /// Of those, the pixels whose change was measured; the others are `rejected`.
    pub measured: usize,
    pub rejected: Rejected,
    /// Mean over the measured pixels' R, G and B of |later - earlier|; `None` when no pixel
    /// was measured.
    pub mean_absolute: Option<f64>,
    /// Root mean square of the same differences; `None` when no pixel was measured.
    pub rms: Option<f64>,
}

/// One pair of consecutive frames.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Pair {
    /// Whether the matrices differ, so the pixels were reprojected (otherwise each was
    /// compared with the same pixel).
    pub camera_moved: bool,
    #[serde(flatten)]
    pub change: Change,
}

/// A sequence's pairs, in order, and all of them pooled (every measured pixel of every pair
/// weighs the same).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Sequence {
    pub pairs: Vec<Pair>,
    pub total: Change,
}

/// Counts and sums in f64, pooled across pairs before anything is divided.
#[derive(Clone, Copy, Debug, Default)]
struct Tally {
    inside_mask: usize,
    measured: usize,
    rejected: Rejected,
    absolute: f64,
    squared: f64,
}

impl Tally {
    fn add(&mut self, later: [f64; 3], earlier: [f32; 4]) {
        self.measured += 1;
        for c in 0..3 {
            let e = later[c] - f64::from(earlier[c]);
            self.absolute += e.abs();
            self.squared += e * e;
        }
    }

    fn merge(&mut self, o: &Tally) {
        self.inside_mask += o.inside_mask;
        self.measured += o.measured;
        self.rejected.no_depth += o.rejected.no_depth;
        self.rejected.outside_frame += o.rejected.outside_frame;
        self.rejected.depth_mismatch += o.rejected.depth_mismatch;
        self.rejected.non_finite += o.rejected.non_finite;
        self.absolute += o.absolute;
        self.squared += o.squared;
    }

    fn change(&self) -> Change {
        let values = (3 * self.measured) as f64;
        let measured = self.measured > 0;
        Change {
            inside_mask: self.inside_mask,
            measured: self.measured,
            rejected: self.rejected,
            mean_absolute: measured.then(|| self.absolute / values),
            rms: measured.then(|| (self.squared / values).sqrt()),
        }
    }
}

/// The change over the frames at `paths`, in order, read one at a time (two are held), each
/// measured inside its own `mask`.
pub fn measure_files(
    paths: &[PathBuf],
    mask: Mask,
    depth_tolerance: f64,
    limits: &Limits,
) -> Result<Sequence, TemporalError> {
    if paths.len() < 2 {
        return Err(TemporalError::TooFewFrames(paths.len()));
    }
    let mut earlier = Frame::read(&paths[0], mask, limits)?;
    let (mut pairs, mut total) = (Vec::new(), Tally::default());
    for path in &paths[1..] {
        let later = Frame::read(path, mask, limits)?;
        let (camera_moved, tally) = tally_pair(&earlier, &later, depth_tolerance)?;
        total.merge(&tally);
        pairs.push(Pair {
            camera_moved,
            change: tally.change(),
        });
        earlier = later;
    }
    Ok(Sequence {
        pairs,
        total: total.change(),
    })
}

/// The change from `earlier` to `later` inside `earlier`'s mask.
pub fn measure_pair(
    earlier: &Frame,
    later: &Frame,
    depth_tolerance: f64,
) -> Result<Pair, TemporalError> {
    let (camera_moved, tally) = tally_pair(earlier, later, depth_tolerance)?;
    Ok(Pair {
        camera_moved,
        change: tally.change(),
    })
}

fn tally_pair(a: &Frame, b: &Frame, tolerance: f64) -> Result<(bool, Tally), TemporalError> {
    if !(tolerance >= 0.0 && tolerance.is_finite()) {
        return Err(TemporalError::Tolerance(tolerance));
    }
    check_same_window(&a.rgba, &a.path, &b.rgba, &b.path)?;
    for f in [a, b] {
        let n = f.rgba.width * f.rgba.height;
        let mask = f.inside.as_ref().map_or(n, Vec::len);
        if (f.rgba.pixels.len(), f.z.len(), mask) != (n, n, n) {
            return Err(TemporalError::Inconsistent(f.path.clone()));
        }
    }
    let camera_moved = a.view != b.view;
    let reprojection = if camera_moved {
        Some(Reprojection::new(a, b)?)
    } else {
        None
    };
    let (width, height) = (a.rgba.width, a.rgba.height);
    let mut t = Tally::default();
    for i in 0..width * height {
        if a.inside.as_ref().is_some_and(|inside| !inside[i]) {
            continue;
        }
        t.inside_mask += 1;
        let p = a.rgba.pixels[i];
        if !p[..3].iter().all(|v| v.is_finite()) {
            t.rejected.non_finite += 1;
            continue;
        }
        let later = match &reprojection {
            None => Ok(b.rgba.pixels[i].map(f64::from)),
            Some(r) => r.sample(a, b, i, tolerance),
        };
        match later {
            Ok(q) if q[..3].iter().all(|v| v.is_finite()) => t.add([q[0], q[1], q[2]], p),
            Ok(_) => t.rejected.non_finite += 1,
            Err(Reject::NoDepth) => t.rejected.no_depth += 1,
            Err(Reject::OutsideFrame) => t.rejected.outside_frame += 1,
            Err(Reject::DepthMismatch) => t.rejected.depth_mismatch += 1,
        }
    }
    Ok((camera_moved, t))
}

enum Reject {
    NoDepth,
    OutsideFrame,
    DepthMismatch,
}

/// A pair's camera motion, as glam matrices for column vectors (an OpenEXR matrix for row
/// vectors read column by column is its transpose).
struct Reprojection {
    /// Earlier frame: camera space to NDC (homogeneous) and back to the world.
    camera_to_ndc: DMat4,
    camera_to_world: DMat4,
    /// Later frame: world to camera space and to NDC.
    world_to_camera: DMat4,
    world_to_ndc: DMat4,
}

impl Reprojection {
    fn new(a: &Frame, b: &Frame) -> Result<Reprojection, TemporalError> {
        let matrix = |frame: &Frame, m: &[f32; 16], attribute| {
            let g = DMat4::from_cols_array(&m.map(f64::from));
            if g.is_finite() {
                Ok(g)
            } else {
                Err(TemporalError::BadMatrix {
                    file: frame.path.clone(),
                    attribute,
                    problem: "is not finite",
                })
            }
        };
        let a_world_to_camera = matrix(a, &a.view.world_to_camera, "worldToCamera")?;
        let camera_to_world = a_world_to_camera.inverse();
        let det = a_world_to_camera.determinant();
        if !(det.abs() > 1e-12 && camera_to_world.is_finite()) {
            return Err(TemporalError::BadMatrix {
                file: a.path.clone(),
                attribute: "worldToCamera",
                problem: "cannot be inverted",
            });
        }
        Ok(Reprojection {
            camera_to_ndc: matrix(a, &a.view.world_to_ndc, "worldToNDC")? * camera_to_world,
            camera_to_world,
            world_to_camera: matrix(b, &b.view.world_to_camera, "worldToCamera")?,
            world_to_ndc: matrix(b, &b.view.world_to_ndc, "worldToNDC")?,
        })
    }

    /// `b` sampled where pixel `i` of `a` lands, if that is the same surface.
    fn sample(&self, a: &Frame, b: &Frame, i: usize, tolerance: f64) -> Result<[f64; 4], Reject> {
        let z = f64::from(a.z[i]);
        if !(z.is_finite() && z > 0.0) {
            return Err(Reject::NoDepth);
        }
        let (x, y) = (i % a.rgba.width, i / a.rgba.width);
        let u = ndc(a.rgba.x0, x, &a.view, 0);
        let v = ndc(a.rgba.y0, y, &a.view, 1);
        let point = self.world_point(u, v, z).ok_or(Reject::OutsideFrame)?;
        let depth = self.world_to_camera.project_point3(point).z;
        let clip = self.world_to_ndc * point.extend(1.0);
        if !(depth > 0.0 && clip.w > 0.0) {
            return Err(Reject::OutsideFrame);
        }
        let sx = pixel(clip.x / clip.w, b.rgba.x0, &b.view, 0);
        let sy = pixel(clip.y / clip.w, b.rgba.y0, &b.view, 1);
        let footprint =
            bilinear(sx, sy, b.rgba.width, b.rgba.height).ok_or(Reject::OutsideFrame)?;
        let mut sum = [0.0f64; 4];
        for (j, w) in footprint.into_iter().flatten() {
            let zb = f64::from(b.z[j]);
            if !(zb.is_finite() && (zb - depth).abs() <= tolerance * depth) {
                return Err(Reject::DepthMismatch);
            }
            for c in 0..4 {
                sum[c] += w * f64::from(b.rgba.pixels[j][c]);
            }
        }
        Ok(sum)
    }

    /// The world point at camera-space depth `z` that the earlier frame sees at NDC (u, v):
    /// camera x and y solve X - u W = 0 and Y - v W = 0 of the projection, linear in them.
    fn world_point(&self, u: f64, v: f64, z: f64) -> Option<DVec3> {
        let m = &self.camera_to_ndc;
        let r = m.row(0) - u * m.row(3);
        let s = m.row(1) - v * m.row(3);
        let det = r.x * s.y - r.y * s.x;
        let (cr, cs) = (-(r.z * z + r.w), -(s.z * z + s.w));
        let cx = (cr * s.y - r.y * cs) / det;
        let cy = (r.x * cs - cr * s.x) / det;
        let world = self.camera_to_world * DVec4::new(cx, cy, z, 1.0);
        let point = world.truncate() / world.w;
        point.is_finite().then_some(point)
    }
}

/// NDC (axis 0: x, 1: y) of the centre of pixel `p` of a data window starting at `origin`.
fn ndc(origin: i32, p: usize, view: &View, axis: usize) -> f64 {
    let display = f64::from(origin) + p as f64 + 0.5 - f64::from(view.display_origin[axis]);
    display / view.display_size[axis] as f64
}

/// The inverse of [`ndc`]: a position in pixels of the data window, centres at whole numbers.
fn pixel(ndc: f64, origin: i32, view: &View, axis: usize) -> f64 {
    let p = ndc * view.display_size[axis] as f64 + f64::from(view.display_origin[axis])
        - f64::from(origin)
        - 0.5;
    let nearest = p.round();
    if (p - nearest).abs() < SNAP {
        nearest
    } else {
        p
    }
}

/// The pixels (by index) and weights of a bilinear sample at (x, y), pixel centres at whole
/// numbers, without the pixels it gives no weight; `None` if it reads outside the window.
fn bilinear(x: f64, y: f64, width: usize, height: usize) -> Option<[Option<(usize, f64)>; 4]> {
    if !(x > -1.0 && x < width as f64 && y > -1.0 && y < height as f64) {
        return None;
    }
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let mut out = [None; 4];
    for (k, (dx, dy)) in [(0, 0), (1, 0), (0, 1), (1, 1)].into_iter().enumerate() {
        let w = if dx == 0 { 1.0 - fx } else { fx } * if dy == 0 { 1.0 - fy } else { fy };
        if w == 0.0 {
            continue;
        }
        let (px, py) = (x0 as i64 + dx, y0 as i64 + dy);
        if px < 0 || py < 0 || px >= width as i64 || py >= height as i64 {
            return None;
        }
        out[k] = Some((px as usize + width * py as usize, w));
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::{Aovs, Camera, Film};

    const WIDTH: u32 = 64;
    const HEIGHT: u32 = 48;
    const VFOV: f64 = 40.0;

    /// A world the tests render exactly: a textured plane facing +Z at `z = -plane` below
    /// `top` (sky above it), and optionally an untextured square nearer the eyes.
    struct World {
        plane: f64,
        top: f64,
        occluder: Option<Occluder>,
    }

    /// A square facing +Z at `z = -depth` over `lo..hi` in x and y.
    struct Occluder {
        depth: f64,
        lo: [f64; 2],
        hi: [f64; 2],
    }

    /// A colour that varies smoothly with the world position: 30 pixels a period or more at
    /// the plane's depth in these tests, so that a bilinear sample is nearly exact.
    fn texture(p: DVec3) -> [f32; 3] {
        let wave = |x: f64, period: f64| (std::f64::consts::TAU * x / period).sin();
        let v = 0.5 + 0.3 * wave(p.x, 4.6) * wave(p.y, 6.2);
        [
            v as f32,
            (0.7 * v) as f32,
            (0.4 + 0.2 * wave(p.x + p.y, 8.0)) as f32,
        ]
    }

    impl World {
        /// The frame `camera` sees: colour (alpha 1 on a surface, 0 and black on the sky),
        /// `Z` from the same camera, and `canopy.A` from `canopy(x, y)`.
        fn render(&self, camera: &Camera, canopy: impl Fn(u32, u32) -> f32) -> Film {
            let mut film = Film::new(0, 0, camera.width, camera.height, (WIDTH, HEIGHT));
            for y in 0..camera.height {
                for x in 0..camera.width {
                    let i = (x + camera.width * y) as usize;
                    let dir = camera.direction(x as f64 + 0.5, y as f64 + 0.5).as_dvec3();
                    film.canopy[i] = canopy(x, y);
                    let Some((t, rgb)) = self.hit(camera.eye, dir) else {
                        continue;
                    };
                    film.rgba[i] = [rgb[0], rgb[1], rgb[2], 1.0];
                    film.z[i] = camera.depth((dir * t).as_vec3());
                }
            }
            film
        }

        fn hit(&self, eye: DVec3, dir: DVec3) -> Option<(f64, [f32; 3])> {
            let at = |depth: f64| (-depth - eye.z) / dir.z;
            if let Some(o) = &self.occluder {
                let t = at(o.depth);
                let p = eye + dir * t;
                if t > 0.0 && (o.lo[0]..o.hi[0]).contains(&p.x) && (o.lo[1]..o.hi[1]).contains(&p.y)
                {
                    return Some((t, [0.9, 0.1, 0.1]));
                }
            }
            let t = at(self.plane);
            let p = eye + dir * t;
            (t > 0.0 && p.y < self.top).then(|| (t, texture(p)))
        }
    }

    fn camera(eye: DVec3, target: DVec3) -> Camera {
        Camera::look_at(eye, target, VFOV, WIDTH, HEIGHT).unwrap()
    }

    /// Writes `film` as `texel render` does, with `camera`'s matrices and `canopy.A`.
    fn write(dir: &Path, name: &str, film: &Film, camera: &Camera) -> PathBuf {
        let aovs = Aovs {
            canopy: true,
            ..Aovs::default()
        };
        let exr = film
            .exr_bytes(
                false,
                aovs,
                camera.world_to_camera(),
                camera.world_to_ndc(),
                None,
            )
            .unwrap();
        let path = dir.join(name);
        std::fs::write(&path, exr.bytes).unwrap();
        path
    }

    fn read(path: &Path, mask: Option<&str>) -> Frame {
        let mask = Mask {
            inside: mask,
            outside: None,
        };
        Frame::read(path, mask, &Limits::default()).unwrap()
    }

    fn everywhere(_: u32, _: u32) -> f32 {
        1.0
    }

    /// The world of most tests: the plane 10 m ahead, sky over its upper third.
    fn plane() -> World {
        World {
            plane: 10.0,
            top: 1.2,
            occluder: None,
        }
    }

    #[test]
    fn a_static_sequence_changes_by_exactly_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let c = camera(DVec3::ZERO, DVec3::NEG_Z);
        let film = plane().render(&c, everywhere);
        assert!(film.z.iter().any(|z| z.is_infinite()), "the test needs sky");
        let paths: Vec<PathBuf> = (0..3)
            .map(|n| write(dir.path(), &format!("{n}.exr"), &film, &c))
            .collect();
        let s = measure_files(
            &paths,
            Mask::ALL,
            DEFAULT_DEPTH_TOLERANCE,
            &Limits::default(),
        )
        .unwrap();
        let pixels = (WIDTH * HEIGHT) as usize;
        assert_eq!(s.pairs.len(), 2);
        for pair in &s.pairs {
            assert!(!pair.camera_moved);
            // The same camera compares every pixel with itself, the sky's too.
            assert_eq!(
                (pair.change.inside_mask, pair.change.measured),
                (pixels, pixels)
            );
            assert_eq!(pair.change.mean_absolute, Some(0.0));
            assert_eq!(pair.change.rms, Some(0.0));
        }
        assert_eq!(s.total.measured, 2 * pixels);
        assert_eq!((s.total.mean_absolute, s.total.rms), (Some(0.0), Some(0.0)));
    }

    /// Frames alternating between c + a and c - a in every colour channel change by 2a from
    /// each frame to the next: the mean absolute change of R, G and B is the flicker's
    /// peak-to-peak amplitude 2a, and so is its RMS (every difference is +-2a).
    #[test]
    fn a_flicker_of_plus_and_minus_a_measures_2a() {
        let dir = tempfile::tempdir().unwrap();
        let c = camera(DVec3::ZERO, DVec3::NEG_Z);
        let (base, a) = (0.5f32, 0.1f32);
        let paths: Vec<PathBuf> = (0..5)
            .map(|n| {
                let mut film = plane().render(&c, everywhere);
                let v = if n % 2 == 0 { base + a } else { base - a };
                film.rgba.fill([v, v, v, 1.0]);
                write(dir.path(), &format!("{n}.exr"), &film, &c)
            })
            .collect();
        let s = measure_files(
            &paths,
            Mask::ALL,
            DEFAULT_DEPTH_TOLERANCE,
            &Limits::default(),
        )
        .unwrap();
        let two_a = f64::from(base + a) - f64::from(base - a);
        assert!((two_a - 0.2).abs() < 1e-6);
        assert_eq!(s.pairs.len(), 4);
        for change in s.pairs.iter().map(|p| p.change).chain([s.total]) {
            assert_eq!(change.measured, change.inside_mask);
            assert!(
                (change.mean_absolute.unwrap() - two_a).abs() < 1e-12,
                "{change:?}"
            );
            assert!((change.rms.unwrap() - two_a).abs() < 1e-12, "{change:?}");
        }
    }

    /// A camera moving sideways and turning to keep a point in view: reprojected, the textured
    /// plane changes only by the bilinear sample's error; compared pixel for pixel (the same
    /// frames with the first frame's matrices) the texture's motion shows as a large change.
    #[test]
    fn a_moving_camera_changes_little_once_its_motion_is_undone() {
        let dir = tempfile::tempdir().unwrap();
        let target = DVec3::new(0.0, 0.0, -40.0);
        let world = plane();
        let paths: Vec<PathBuf> = (0..3)
            .map(|n| {
                let eye = DVec3::new(0.6 * n as f64, 0.05 * n as f64, 0.2 * n as f64);
                let c = camera(eye, target);
                write(
                    dir.path(),
                    &format!("{n}.exr"),
                    &world.render(&c, everywhere),
                    &c,
                )
            })
            .collect();
        let s = measure_files(
            &paths,
            Mask::ALL,
            DEFAULT_DEPTH_TOLERANCE,
            &Limits::default(),
        )
        .unwrap();
        let undone = s.total.mean_absolute.unwrap();
        let (a, b) = (read(&paths[0], None), read(&paths[1], None));
        let still = Frame {
            view: a.view,
            ..b.clone()
        };
        let kept = measure_pair(&a, &still, DEFAULT_DEPTH_TOLERANCE).unwrap();
        assert!(!kept.camera_moved && s.pairs.iter().all(|p| p.camera_moved));
        let kept = kept.change.mean_absolute.unwrap();
        println!("mean |change|: {undone:.6} reprojected, {kept:.6} pixel for pixel");
        assert!(undone < 0.001, "{s:?}");
        assert!(kept > 20.0 * undone, "{kept} {undone}");
        // Most of the plane is measured; the sky is not (the camera moved), nor the plane's
        // top row where its bilinear sample would read the sky.
        let first = s.pairs[0].change;
        assert!(first.measured > first.inside_mask / 2, "{first:?}");
        assert!(first.rejected.no_depth > 0 && first.rejected.depth_mismatch < 2 * WIDTH as usize);
        assert_eq!(first.measured + first.rejected.total(), first.inside_mask);
    }

    /// The eye moves right by two pixels' worth at the plane's depth (four at the square's,
    /// halfway), so each point lands a whole number of pixels to the left: the rejections are
    /// known pixel by pixel from the pictures alone.
    #[test]
    fn points_that_leave_the_frame_or_are_hidden_are_rejected() {
        let dir = tempfile::tempdir().unwrap();
        let world = World {
            occluder: Some(Occluder {
                depth: 5.0,
                lo: [-0.6, -0.5],
                hi: [0.3, 0.4],
            }),
            ..plane()
        };
        let pixel = 2.0 * world.plane * (0.5 * VFOV).to_radians().tan() / f64::from(HEIGHT);
        let cameras = [0.0, 2.0 * pixel].map(|x| {
            let eye = DVec3::new(x, 0.0, 0.0);
            camera(eye, eye + DVec3::NEG_Z)
        });
        let films = cameras.each_ref().map(|c| world.render(c, everywhere));
        let paths = [0, 1].map(|n| write(dir.path(), &format!("{n}.exr"), &films[n], &cameras[n]));
        let (a, b) = (read(&paths[0], None), read(&paths[1], None));
        let got = measure_pair(&a, &b, DEFAULT_DEPTH_TOLERANCE)
            .unwrap()
            .change;

        let w = WIDTH as usize;
        let mut want = Rejected::default();
        for (i, &z) in films[0].z.iter().enumerate() {
            let (x, y) = (i % w, i / w);
            let shift = if z.is_infinite() {
                want.no_depth += 1;
                continue;
            } else if z < 7.5 {
                4
            } else {
                2
            };
            if x < shift {
                want.outside_frame += 1;
            } else if (films[1].z[x - shift + w * y] - z).abs() > 0.05 * z {
                want.depth_mismatch += 1;
            }
        }
        assert!(want.no_depth > 0 && want.outside_frame > 0 && want.depth_mismatch > 0);
        assert_eq!(got.rejected, want);
        assert_eq!(got.measured + want.total(), (WIDTH * HEIGHT) as usize);
        // What is measured is the same surface, sampled at its own pixel centre.
        assert!(got.mean_absolute.unwrap() < 1e-5, "{got:?}");
        // A tolerance wider than the square's distance from the plane takes it for the plane.
        let blind = measure_pair(&a, &b, 1.5).unwrap().change;
        assert_eq!(blind.rejected.depth_mismatch, 0);
        assert_eq!(blind.measured, got.measured + want.depth_mismatch);
        assert!(blind.rms.unwrap() > 0.01, "{blind:?}");
    }

    /// Flicker on the right half only: inside a mask of the left half nothing changes, over
    /// the whole frame half the pixels change by 2a.
    #[test]
    fn the_mask_restricts_the_measure_to_the_frames_own_channel() {
        let dir = tempfile::tempdir().unwrap();
        let c = camera(DVec3::ZERO, DVec3::NEG_Z);
        let left = |x: u32, _| if x < WIDTH / 2 { 1.0 } else { 0.0 };
        let paths: Vec<PathBuf> = (0..3)
            .map(|n| {
                let mut film = plane().render(&c, left);
                for (i, p) in film.rgba.iter_mut().enumerate() {
                    if i % WIDTH as usize >= WIDTH as usize / 2 {
                        *p = [0.3 + 0.1 * (n % 2) as f32, 0.3, 0.3, 1.0];
                    }
                }
                write(dir.path(), &format!("{n}.exr"), &film, &c)
            })
            .collect();
        let limits = Limits::default();
        let masked = measure_files(&paths, Mask::inside("canopy.A"), 0.05, &limits).unwrap();
        let half = (WIDTH * HEIGHT / 2) as usize;
        assert_eq!(
            (masked.total.inside_mask, masked.total.measured),
            (2 * half, 2 * half)
        );
        assert_eq!(masked.total.mean_absolute, Some(0.0));
        let all = measure_files(&paths, Mask::ALL, 0.05, &limits).unwrap();
        assert_eq!(all.total.measured, 4 * half);
        // Half the pixels change in R alone: a sixth of the values, by 0.1.
        let mean = all.total.mean_absolute.unwrap();
        assert!((mean - 0.1 / 6.0).abs() < 1e-6, "{mean}");
        // Leaving the mask's pixels out measures the other half, where R changes by 0.1; so
        // does taking them in and leaving them all out again, which leaves nothing.
        let outside = Mask {
            inside: None,
            outside: Some("canopy.A"),
        };
        let right = measure_files(&paths, outside, 0.05, &limits).unwrap();
        assert_eq!(right.total.measured, 2 * half);
        let mean = right.total.mean_absolute.unwrap();
        assert!((mean - 0.1 / 3.0).abs() < 1e-6, "{mean}");
        let neither = Mask {
            inside: Some("canopy.A"),
            outside: Some("canopy.A"),
        };
        let s = measure_files(&paths, neither, 0.05, &limits).unwrap();
        assert_eq!(s.total.measured, 0);
        // A mask that takes nothing in measures nothing, and says so rather than divide by 0.
        let none = |_, _| 0.0;
        let film = plane().render(&c, none);
        let empty = [0, 1].map(|n| write(dir.path(), &format!("e{n}.exr"), &film, &c));
        let s = measure_files(&empty, Mask::inside("canopy.A"), 0.05, &limits).unwrap();
        assert_eq!(s.total, Change::default());
        // A channel the frames lack is named with the file.
        let e = measure_files(&paths, Mask::inside("canopy.X"), 0.05, &limits).unwrap_err();
        assert!(
            e.to_string().contains("0.exr") && e.to_string().contains("no channel canopy.X"),
            "{e}"
        );
    }

    /// Colours that are not finite are counted, never averaged: no NaN reaches the measure.
    #[test]
    fn non_finite_colours_are_rejected() {
        let dir = tempfile::tempdir().unwrap();
        let c = camera(DVec3::ZERO, DVec3::NEG_Z);
        let film = plane().render(&c, everywhere);
        let a = write(dir.path(), "a.exr", &film, &c);
        let mut frame = read(&a, None);
        let mut later = frame.clone();
        frame.rgba.pixels[3] = [f32::NAN; 4];
        later.rgba.pixels[5] = [f32::INFINITY; 4];
        let change = measure_pair(&frame, &later, 0.05).unwrap().change;
        assert_eq!(change.rejected.non_finite, 2);
        assert_eq!(change.mean_absolute, Some(0.0));
        assert!(measure_pair(&frame, &later, f64::NAN).is_err());
        // A frame put together by hand whose layers disagree is refused, not indexed past.
        later.z.pop();
        assert!(matches!(
            measure_pair(&frame, &later, 0.05),
            Err(TemporalError::Inconsistent(_))
        ));
    }

    /// Frames that cannot be compared are refused with the file and the reason.
    #[test]
    fn unusable_frames_are_refused_by_name() {
        use exr::prelude::*;
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let limits = Limits::default();
        let c = camera(DVec3::ZERO, DVec3::NEG_Z);
        let good = write(d, "good.exr", &plane().render(&c, everywhere), &c);
        let error = |paths: &[PathBuf]| {
            measure_files(paths, Mask::ALL, 0.05, &limits)
                .unwrap_err()
                .to_string()
        };
        // Colour without depth, and colour and depth without the camera's matrices.
        let column = |v: f32| FlatSamples::F32(vec![v; (WIDTH * HEIGHT) as usize]);
        let save = |name: &str, names: &[&str], attributes: LayerAttributes| {
            let channels: Vec<_> = names
                .iter()
                .map(|n| AnyChannel::new(*n, column(1.0)))
                .collect();
            let path = d.join(name);
            Image::from_layer(Layer::new(
                (WIDTH as usize, HEIGHT as usize),
                attributes,
                Encoding::UNCOMPRESSED,
                AnyChannels::sort(channels.into()),
            ))
            .write()
            .to_file(&path)
            .unwrap();
            path
        };
        let no_z = save(
            "no-z.exr",
            &["R", "G", "B", "A"],
            LayerAttributes::default(),
        );
        let e = error(&[good.clone(), no_z]);
        assert!(e.contains("no-z.exr") && e.contains("no channel Z"), "{e}");
        let no_camera = save(
            "no-camera.exr",
            &["R", "G", "B", "A", "Z"],
            Default::default(),
        );
        let e = error(&[good.clone(), no_camera]);
        assert!(
            e.contains("no-camera.exr") && e.contains("worldToCamera"),
            "{e}"
        );
        let singular = save(
            "singular.exr",
            &["R", "G", "B", "A", "Z"],
            LayerAttributes {
                world_to_camera: Some([0.0; 16]),
                world_to_normalized_device: Some(c.world_to_ndc()),
                ..Default::default()
            },
        );
        let e = error(&[singular, good.clone()]);
        assert!(
            e.contains("singular.exr") && e.contains("cannot be inverted"),
            "{e}"
        );
        // Matrices in double precision (OpenEXR's m44d) are the camera's too. The exr crate
        // writes no m44d under the standard names: written under names of the same length,
        // then renamed in the file's bytes.
        let double = |m: [f32; 16]| AttributeValue::Custom {
            kind: Text::from("m44d"),
            bytes: m.iter().flat_map(|&v| f64::from(v).to_le_bytes()).collect(),
        };
        let mut attributes = LayerAttributes::default();
        let standins = [
            ("worldToCamerQ", "worldToCamera", c.world_to_camera()),
            ("worldToNDQ", "worldToNDC", c.world_to_ndc()),
        ];
        for (standin, _, m) in standins {
            attributes.other.insert(Text::from(standin), double(m));
        }
        let doubles = save("m44d.exr", &["R", "G", "B", "A", "Z"], attributes);
        let mut bytes = std::fs::read(&doubles).unwrap();
        for (standin, name, _) in standins {
            let at = bytes
                .windows(standin.len())
                .position(|w| w == standin.as_bytes())
                .unwrap();
            bytes[at..at + name.len()].copy_from_slice(name.as_bytes());
        }
        std::fs::write(&doubles, bytes).unwrap();
        // Read as the very matrices `good` holds in m44f: the same camera, not reprojected.
        let pair = measure_files(&[good.clone(), doubles], Mask::ALL, 0.05, &limits).unwrap();
        assert!(!pair.pairs[0].camera_moved);
        let small = camera(DVec3::ZERO, DVec3::NEG_Z);
        let small = Camera { width: 8, ..small };
        let small = write(d, "small.exr", &plane().render(&small, everywhere), &small);
        let e = error(&[good.clone(), small]);
        assert!(e.contains("small.exr") && e.contains("same size"), "{e}");
        let e = error(&[good.clone(), d.join("missing.exr")]);
        assert!(
            e.contains("missing.exr") && e.contains("cannot read"),
            "{e}"
        );
        assert!(error(std::slice::from_ref(&good)).contains("at least two frames"));
    }
}
