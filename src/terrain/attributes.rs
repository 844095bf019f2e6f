//! Terrain attributes on a height raster, each a documented formula (see `formats/species.md`):
//!
//! * **slope** (degrees): `atan |grad h|`, the gradient by Horn's 3 x 3 operator;
//! * **aspect** (degrees clockwise from north, the compass bearing the slope faces; -1 on flats);
//! * **topographic position** (metres): `h` minus the mean height within a radius (positive on
//!   ridges, negative in valleys);
//! * **wetness**: the topographic wetness index `ln(a / tan b)`, with `a` the specific catchment
//!   area (upslope area per unit contour width, metres) from multiple-flow-direction
//!   accumulation and `b` the slope, `tan b` floored at 0.001.

use rayon::prelude::*;

use super::Heightfield;

/// Names of the attributes, in the order [`Attributes::get`] numbers them.
pub const TERRAIN_ATTRIBUTES: [&str; 5] = [
    "elevation",
    "slope",
    "aspect",
    "topographic_position",
    "wetness",
];

/// Freeman's (1991) flow-partition exponent.
const MFD_EXPONENT: f64 = 1.1;
const MIN_TAN_SLOPE: f64 = 0.001;

#[derive(Clone, Debug)]
pub struct Attributes {
    pub slope: Vec<f32>,
    pub aspect: Vec<f32>,
    pub topographic_position: Vec<f32>,
    pub wetness: Vec<f32>,
    /// Upslope contributing area of each cell, in cells (for pictures and tests).
    pub flow: Vec<f32>,
}

impl Attributes {
    /// Attribute `k` of [`TERRAIN_ATTRIBUTES`], elevation being the raster itself.
    pub fn get<'a>(&'a self, field: &'a Heightfield, k: usize) -> &'a [f32] {
        match k {
            0 => &field.height,
            1 => &self.slope,
            2 => &self.aspect,
            3 => &self.topographic_position,
            _ => &self.wetness,
        }
    }

    pub fn compute(field: &Heightfield, tpi_radius: f64) -> Attributes {
        let (slope, aspect) = slope_aspect(field);
        let topographic_position = topographic_position(field, tpi_radius);
        let flow = flow_accumulation(field);
        let wetness = (0..field.height.len())
            .map(|k| {
                if field.height[k].is_nan() {
                    return f32::NAN;
                }
                let a = flow[k] as f64 * field.cell; // area (cells x cell^2) per contour width (cell)
                let tan_b = (slope[k] as f64).to_radians().tan().max(MIN_TAN_SLOPE);
                (a / tan_b).ln() as f32
            })
            .collect();
        Attributes {
            slope,
            aspect,
            topographic_position,
            wetness,
            flow,
        }
    }
}

/// Illumination of the raster by a light from the north-west, 45 degrees up, as cartographers
/// shade relief: cos(zenith) cos(slope) + sin(zenith) sin(slope) cos(azimuth - aspect), in 0..1.
pub fn hillshade(field: &Heightfield) -> Vec<f32> {
    let (slope, aspect) = slope_aspect(field);
    let (zenith, azimuth) = (45f64.to_radians(), 315f64.to_radians());
    slope
        .iter()
        .zip(&aspect)
        .map(|(&s, &a)| {
            if s.is_nan() {
                return f32::NAN;
            }
            let s = (s as f64).to_radians();
            let across = if a < 0.0 {
                0.0
            } else {
                (azimuth - (a as f64).to_radians()).cos()
            };
            (zenith.cos() * s.cos() + zenith.sin() * s.sin() * across).max(0.0) as f32
        })
        .collect()
}

/// Horn's operator: each derivative from the six neighbours across the centre, weighted 1 2 1.
/// Neighbours outside the raster or without terrain take the centre's height.
fn slope_aspect(f: &Heightfield) -> (Vec<f32>, Vec<f32>) {
    let n = f.height.len();
    let (mut slope, mut aspect) = (vec![f32::NAN; n], vec![f32::NAN; n]);
    for j in 0..f.nz {
        for i in 0..f.nx {
            let centre = f.at(i, j);
            if centre.is_nan() {
                continue;
            }
            let h = |di: isize, dj: isize| -> f64 {
                let (a, b) = (i as isize + di, j as isize + dj);
                if a < 0 || b < 0 || a >= f.nx as isize || b >= f.nz as isize {
                    return centre as f64;
                }
                let v = f.at(a as usize, b as usize);
                if v.is_nan() { centre as f64 } else { v as f64 }
            };
            let dhdx = ((h(1, -1) + 2.0 * h(1, 0) + h(1, 1))
                - (h(-1, -1) + 2.0 * h(-1, 0) + h(-1, 1)))
                / (8.0 * f.cell);
            let dhdz = ((h(-1, 1) + 2.0 * h(0, 1) + h(1, 1))
                - (h(-1, -1) + 2.0 * h(0, -1) + h(1, -1)))
                / (8.0 * f.cell);
            let k = i + f.nx * j;
            slope[k] = dhdx.hypot(dhdz).atan().to_degrees() as f32;
            // The slope faces downhill: east component -dh/dx, north component +dh/dz (z is south).
            aspect[k] = if dhdx == 0.0 && dhdz == 0.0 {
                -1.0
            } else {
                (-dhdx).atan2(dhdz).to_degrees().rem_euclid(360.0) as f32
            };
        }
    }
    (slope, aspect)
}

/// Height minus the mean height of the cells whose centres lie within `radius` (a disc),
/// computed with per-row prefix sums.
fn topographic_position(f: &Heightfield, radius: f64) -> Vec<f32> {
    // A disc wider than the raster's diagonal covers all of it: no need to look further (and
    // a radius of 1e308 metres must not loop over rows that do not exist).
    let diagonal = (f.nx as f64).hypot(f.nz as f64) + 1.0;
    let r = (radius / f.cell).clamp(1.0, diagonal);
    let reach = r.floor() as isize;
    // Prefix sums of height and of valid-cell counts along each row.
    let mut sum = vec![0.0f64; (f.nx + 1) * f.nz];
    let mut count = vec![0u32; (f.nx + 1) * f.nz];
    for j in 0..f.nz {
        for i in 0..f.nx {
            let v = f.at(i, j);
            let (s, c) = if v.is_nan() { (0.0, 0) } else { (v as f64, 1) };
            sum[(f.nx + 1) * j + i + 1] = sum[(f.nx + 1) * j + i] + s;
            count[(f.nx + 1) * j + i + 1] = count[(f.nx + 1) * j + i] + c;
        }
    }
    // Row by row (rows in parallel), each row of the disc added to every cell of the row in
    // turn: the prefix sums are read in sweeps along their rows, not in a column of scattered
    // reads per cell (which left this bound by cache misses: 25 s at half a metre a cell on
    // a 1 km terrain). Each cell still adds its disc's rows in the same order, so the sums,
    // and the result, have the same bits.
    let mut out = vec![f32::NAN; f.height.len()];
    out.par_chunks_mut(f.nx).enumerate().for_each(|(j, out)| {
        let mut s = vec![0.0f64; f.nx];
        let mut c = vec![0u32; f.nx];
        let rows = (-reach).max(-(j as isize))..=reach.min((f.nz - 1 - j) as isize);
        for dj in rows {
            let row = j as isize + dj;
            let half = ((r * r - (dj * dj) as f64).max(0.0)).sqrt().floor() as isize;
            let base = (f.nx + 1) * row as usize;
            let (sum, count) = (&sum[base..base + f.nx + 1], &count[base..base + f.nx + 1]);
            for i in 0..f.nx {
                let a = (i as isize - half).max(0) as usize;
                let b = ((i as isize + half + 1) as usize).min(f.nx);
                s[i] += sum[b] - sum[a];
                c[i] += count[b] - count[a];
            }
        }
        for (i, o) in out.iter_mut().enumerate() {
            let centre = f.at(i, j);
            if !centre.is_nan() {
                *o = (centre as f64 - s[i] / c[i].max(1) as f64) as f32;
            }
        }
    });
    out
}

/// Multiple-flow-direction accumulation (Freeman 1991): every cell starts with its own area
/// (1 cell) and passes what it holds to all lower neighbours in proportion to
/// `(drop / distance)^1.1`; cells are visited from the highest down. Pits keep their flow;
/// flow leaving the raster is lost.
fn flow_accumulation(f: &Heightfield) -> Vec<f32> {
    let n = f.height.len();
    let mut order: Vec<usize> = (0..n).filter(|&k| !f.height[k].is_nan()).collect();
    // Highest first; ties by index so the order (and the result) is reproducible.
    order.sort_by(|&a, &b| f.height[b].total_cmp(&f.height[a]).then(a.cmp(&b)));
    let mut flow = vec![1.0f64; n];
    let mut weights = [(0usize, 0.0f64); 8];
    for &k in &order {
        let (i, j) = ((k % f.nx) as isize, (k / f.nx) as isize);
        let h = f.height[k] as f64;
        let mut m = 0;
        let mut total = 0.0;
        for dj in -1..=1isize {
            for di in -1..=1isize {
                let (a, b) = (i + di, j + dj);
                if (di == 0 && dj == 0)
                    || a < 0
                    || b < 0
                    || a >= f.nx as isize
                    || b >= f.nz as isize
                {
                    continue;
                }
                let q = a as usize + f.nx * b as usize;
                let hq = f.height[q] as f64;
                if hq.is_nan() || hq >= h {
                    continue;
                }
                let distance = if di != 0 && dj != 0 {
                    std::f64::consts::SQRT_2
                } else {
                    1.0
                } * f.cell;
                let w = ((h - hq) / distance).powf(MFD_EXPONENT);
                weights[m] = (q, w);
                total += w;
                m += 1;
            }
        }
        for &(q, w) in &weights[..m] {
            flow[q] += flow[k] * w / total;
        }
    }
    flow.iter()
        .zip(&f.height)
        .map(|(&a, h)| if h.is_nan() { f32::NAN } else { a as f32 })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field(nx: usize, nz: usize, cell: f64, h: impl Fn(f64, f64) -> f64) -> Heightfield {
        let height = (0..nx * nz)
            .map(|k| {
                h(
                    ((k % nx) as f64 + 0.5) * cell,
                    ((k / nx) as f64 + 0.5) * cell,
                ) as f32
            })
            .collect();
        Heightfield {
            x0: 0.0,
            z0: 0.0,
            cell,
            nx,
            nz,
            height,
        }
    }

    #[test]
    fn a_plane_rising_east_has_its_slope_and_faces_west() {
        let f = field(9, 9, 10.0, |x, _| x * 0.5); // 0.5 m per m: 26.57 degrees
        let a = Attributes::compute(&f, 30.0);
        let k = 4 + 9 * 4;
        assert!((a.slope[k] - 26.565).abs() < 0.01, "{}", a.slope[k]);
        assert!((a.aspect[k] - 270.0).abs() < 1e-3, "{}", a.aspect[k]);
        let north = field(9, 9, 10.0, |_, z| z * 0.1); // rising southwards: faces north
        assert!(Attributes::compute(&north, 30.0).aspect[k].abs() < 1e-3);
        assert!(Attributes::compute(&field(5, 5, 1.0, |_, _| 3.0), 2.0).aspect[12] == -1.0);
    }

    #[test]
    fn ridges_have_positive_and_valleys_negative_topographic_position() {
        // A sine ridge-and-valley pattern along x.
        let f = field(64, 16, 10.0, |x, _| {
            50.0 * (x / 640.0 * std::f64::consts::TAU).sin()
        });
        let a = Attributes::compute(&f, 200.0);
        let ridge = 16 + 64 * 8; // x = 165 m: near the crest
        let valley = 48 + 64 * 8;
        assert!(
            a.topographic_position[ridge] > 15.0,
            "{}",
            a.topographic_position[ridge]
        );
        assert!(
            a.topographic_position[valley] < -15.0,
            "{}",
            a.topographic_position[valley]
        );
        // Valleys collect flow and are wetter than ridges.
        assert!(
            a.wetness[valley] > a.wetness[ridge] + 2.0,
            "{} {}",
            a.wetness[valley],
            a.wetness[ridge]
        );
    }

    #[test]
    fn flow_on_a_tilted_plane_accumulates_downhill_and_conserves_area() {
        // Tilted towards +x: every row drains east, off the raster's edge.
        let f = field(10, 3, 1.0, |x, _| 100.0 - x);
        let a = Attributes::compute(&f, 2.0);
        // The easternmost cells receive everything upslope of them (3 rows x 10 columns = 30
        // cells in all, minus what flowed out sideways: none on a plane tilted along x).
        let east: f32 = (0..3).map(|j| a.flow[9 + 10 * j]).sum();
        assert!((east - 30.0).abs() < 1e-3, "{east}");
        assert!(a.flow[10] == 1.0, "the west edge receives nothing");
    }
}
