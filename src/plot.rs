//! Small plots as PNG-ready pictures, for the reports: log-log line plots (axes with decade
//! ticks, one polyline with markers per series, a legend) and grouped bar charts on a linear
//! axis, with text in a built-in 5 x 7 pixel font (so no font files are needed on the machine
//! that makes the report).

use image::{Rgb, RgbImage};

/// One curve: points (x, y), both positive.
#[derive(Clone, Debug)]
pub struct Series {
    pub name: String,
    pub color: [u8; 3],
    pub points: Vec<(f64, f64)>,
}

#[derive(Clone, Debug)]
pub struct Plot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
}

/// Distinct colours for up to eight series (Okabe and Ito's palette, safe for colour-blind
/// readers).
pub const PALETTE: [[u8; 3]; 8] = [
    [0, 114, 178],
    [230, 159, 0],
    [0, 158, 115],
    [204, 121, 167],
    [86, 180, 233],
    [213, 94, 0],
    [240, 228, 66],
    [0, 0, 0],
];

const SCALE: u32 = 2;
const GLYPH_W: u32 = 6 * SCALE;

/// Rows of a 5 x 7 glyph, five bits each, most significant bit leftmost.
fn glyph(c: char) -> [u8; 7] {
    match c.to_ascii_uppercase() {
        'A' => [14, 17, 17, 31, 17, 17, 17],
        'B' => [30, 17, 17, 30, 17, 17, 30],
        'C' => [14, 17, 16, 16, 16, 17, 14],
        'D' => [28, 18, 17, 17, 17, 18, 28],
        'E' => [31, 16, 16, 30, 16, 16, 31],
        'F' => [31, 16, 16, 30, 16, 16, 16],
        'G' => [14, 17, 16, 23, 17, 17, 15],
        'H' => [17, 17, 17, 31, 17, 17, 17],
        'I' => [14, 4, 4, 4, 4, 4, 14],
        'J' => [7, 2, 2, 2, 2, 18, 12],
        'K' => [17, 18, 20, 24, 20, 18, 17],
        'L' => [16, 16, 16, 16, 16, 16, 31],
        'M' => [17, 27, 21, 21, 17, 17, 17],
        'N' => [17, 17, 25, 21, 19, 17, 17],
        'O' => [14, 17, 17, 17, 17, 17, 14],
        'P' => [30, 17, 17, 30, 16, 16, 16],
        'Q' => [14, 17, 17, 17, 21, 18, 13],
        'R' => [30, 17, 17, 30, 20, 18, 17],
        'S' => [15, 16, 16, 14, 1, 1, 30],
        'T' => [31, 4, 4, 4, 4, 4, 4],
        'U' => [17, 17, 17, 17, 17, 17, 14],
        'V' => [17, 17, 17, 17, 17, 10, 4],
        'W' => [17, 17, 17, 21, 21, 21, 10],
        'X' => [17, 17, 10, 4, 10, 17, 17],
        'Y' => [17, 17, 17, 10, 4, 4, 4],
        'Z' => [31, 1, 2, 4, 8, 16, 31],
        '0' => [14, 17, 19, 21, 25, 17, 14],
        '1' => [4, 12, 4, 4, 4, 4, 14],
        '2' => [14, 17, 1, 2, 4, 8, 31],
        '3' => [31, 2, 4, 2, 1, 17, 14],
        '4' => [2, 6, 10, 18, 31, 2, 2],
        '5' => [31, 16, 30, 1, 1, 17, 14],
        '6' => [6, 8, 16, 30, 17, 17, 14],
        '7' => [31, 1, 2, 4, 8, 8, 8],
        '8' => [14, 17, 17, 14, 17, 17, 14],
        '9' => [14, 17, 17, 15, 1, 2, 12],
        '.' => [0, 0, 0, 0, 0, 12, 12],
        ',' => [0, 0, 0, 0, 12, 4, 8],
        '-' => [0, 0, 0, 31, 0, 0, 0],
        '+' => [0, 4, 4, 31, 4, 4, 0],
        '(' => [2, 4, 8, 8, 8, 4, 2],
        ')' => [8, 4, 2, 2, 2, 4, 8],
        '/' => [0, 1, 2, 4, 8, 16, 0],
        ':' => [0, 12, 12, 0, 12, 12, 0],
        '=' => [0, 0, 31, 0, 31, 0, 0],
        '%' => [24, 25, 2, 4, 8, 19, 3],
        ' ' => [0; 7],
        _ => [31, 17, 17, 17, 17, 17, 31],
    }
}

fn put(img: &mut RgbImage, x: i64, y: i64, c: [u8; 3]) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, Rgb(c));
    }
}

/// Draws `text` with its top-left corner at (x, y).
fn text(img: &mut RgbImage, x: i64, y: i64, s: &str, c: [u8; 3]) {
    for (k, ch) in s.chars().enumerate() {
        let rows = glyph(ch);
        let x0 = x + (k as u32 * GLYPH_W) as i64;
        for (r, bits) in rows.iter().enumerate() {
            for col in 0..5 {
                if bits & (16 >> col) != 0 {
                    for dy in 0..SCALE as i64 {
                        for dx in 0..SCALE as i64 {
                            put(
                                img,
                                x0 + col * SCALE as i64 + dx,
                                y + r as i64 * SCALE as i64 + dy,
                                c,
                            );
                        }
                    }
                }
            }
        }
    }
}

fn text_width(s: &str) -> i64 {
    (s.chars().count() as u32 * GLYPH_W) as i64
}

/// `s` broken at spaces into lines at most `width` pixels wide where its words allow (a word
/// wider than that stands on a line of its own).
fn wrap(s: &str, width: i64) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in s.split_whitespace() {
        match lines.last_mut() {
            Some(l) if text_width(l) + text_width(" ") + text_width(word) <= width => {
                l.push(' ');
                l.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

/// A line `width` pixels thick.
fn line(img: &mut RgbImage, (x0, y0): (f64, f64), (x1, y1): (f64, f64), c: [u8; 3], width: i64) {
    let steps = (x1 - x0).abs().max((y1 - y0).abs()).ceil().max(1.0) as i64;
    for i in 0..=steps {
        let f = i as f64 / steps as f64;
        let (x, y) = (x0 + (x1 - x0) * f, y0 + (y1 - y0) * f);
        for d in 0..width {
            put(img, x as i64 + d - width / 2, y as i64, c);
            put(img, x as i64, y as i64 + d - width / 2, c);
        }
    }
}

/// `v` as a short label: 0.001, 0.02, 5, 300.
fn label(v: f64) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

/// The decades spanning `lo`..`hi` (positive), widened to whole decades.
fn decades(lo: f64, hi: f64) -> (f64, f64) {
    (
        lo.log10().floor(),
        hi.log10().ceil().max(lo.log10().floor() + 1.0),
    )
}

// Margins of the plot area in pixels: room for the y labels on the left, the title above and
// the x labels and axis name below.
const LEFT: i64 = 90;
const TOP: i64 = 50;
/// The y axis's name sits between the title (rows 10-23) and the top tick's label (from
/// TOP - 7): it may be wider than the left margin.
const Y_LABEL: i64 = TOP - 21;
const BOTTOM: i64 = 70;

const BLACK: [u8; 3] = [0, 0, 0];

/// Whether a point can go on log axes: finite and positive.
fn plottable(&(x, y): &(f64, f64)) -> bool {
    x.is_finite() && y.is_finite() && x > 0.0 && y > 0.0
}

/// The plot area in pixels and the decades it spans, so values map to pixels the same way for
/// the grid, the ticks and the series.
struct Axes {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    /// Decades (log10) at the left and right edges.
    dx: (f64, f64),
    /// Decades (log10) at the bottom and top edges.
    dy: (f64, f64),
}

impl Axes {
    fn px(&self, x: f64) -> f64 {
        let (d0, d1) = self.dx;
        self.x0 + (x.log10() - d0) / (d1 - d0) * (self.x1 - self.x0)
    }

    fn py(&self, y: f64) -> f64 {
        let (d0, d1) = self.dy;
        self.y0 + (y.log10() - d0) / (d1 - d0) * (self.y1 - self.y0)
    }

    /// Grid at 1, 2 and 5 times each decade; labels at 1 (and 2, 5 when decades are few), so
    /// a reader can read values off without the labels crowding.
    fn draw_grid(&self, img: &mut RgbImage) {
        let grey = [220, 220, 220];
        for (d0, d1, horizontal) in [(self.dx.0, self.dx.1, false), (self.dy.0, self.dy.1, true)] {
            for d in d0 as i32..=d1 as i32 {
                for m in [1.0, 2.0, 5.0] {
                    let v = m * 10f64.powi(d);
                    if v.log10() > d1 + 1e-9 {
                        continue;
                    }
                    let labelled = m == 1.0 || d1 - d0 <= 2.0;
                    let shade = if m == 1.0 { [190, 190, 190] } else { grey };
                    if horizontal {
                        let y = self.py(v);
                        line(img, (self.x0, y), (self.x1, y), shade, 1);
                        if labelled {
                            let l = label(v);
                            text(img, LEFT - 8 - text_width(&l), y as i64 - 7, &l, BLACK);
                        }
                    } else {
                        let x = self.px(v);
                        line(img, (x, self.y0), (x, self.y1), shade, 1);
                        if labelled {
                            let l = label(v);
                            text(
                                img,
                                x as i64 - text_width(&l) / 2,
                                self.y0 as i64 + 8,
                                &l,
                                BLACK,
                            );
                        }
                    }
                }
            }
        }
    }
}

impl Plot {
    /// The plot as a `width` x `height` picture. Non-positive or non-finite points are left out.
    pub fn draw(&self, width: u32, height: u32) -> RgbImage {
        let mut img = RgbImage::from_pixel(width, height, Rgb([255, 255, 255]));
        let legend_w = self
            .series
            .iter()
            .map(|s| text_width(&s.name))
            .max()
            .unwrap_or(0)
            + 50;
        text(&mut img, LEFT, 10, &self.title, BLACK);
        let Some(axes) = self.axes(width, height, legend_w) else {
            return img;
        };
        axes.draw_grid(&mut img);
        self.draw_axis_lines(&mut img, &axes, height);
        self.draw_series(&mut img, &axes, width, legend_w);
        img
    }

    /// The plot area left of the legend, spanning whole decades around every plottable point;
    /// `None` when there is no such point, and so nothing to scale the axes to.
    fn axes(&self, width: u32, height: u32, legend_w: i64) -> Option<Axes> {
        let points = || {
            self.series
                .iter()
                .flat_map(|s| s.points.iter())
                .filter(|p| plottable(p))
        };
        let (x_lo, x_hi) = points().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
            (a.min(p.0), b.max(p.0))
        });
        let (y_lo, y_hi) = points().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
            (a.min(p.1), b.max(p.1))
        });
        if !x_lo.is_finite() || !y_lo.is_finite() {
            return None;
        }
        Some(Axes {
            x0: LEFT as f64,
            x1: width as f64 - legend_w as f64 - 20.0,
            y0: height as f64 - BOTTOM as f64,
            y1: TOP as f64,
            dx: decades(x_lo, x_hi),
            dy: decades(y_lo, y_hi),
        })
    }

    /// The two axes and their names, drawn over the grid.
    fn draw_axis_lines(&self, img: &mut RgbImage, axes: &Axes, height: u32) {
        let Axes { x0, x1, y0, y1, .. } = *axes;
        line(img, (x0, y0), (x1, y0), BLACK, 1);
        line(img, (x0, y0), (x0, y1), BLACK, 1);
        text(
            img,
            ((x0 + x1) / 2.0) as i64 - text_width(&self.x_label) / 2,
            height as i64 - 28,
            &self.x_label,
            BLACK,
        );
        text(img, 8, Y_LABEL, &self.y_label, BLACK);
    }

    /// Each series as a polyline with square markers, and its entry in the legend on the right.
    fn draw_series(&self, img: &mut RgbImage, axes: &Axes, width: u32, legend_w: i64) {
        for (k, s) in self.series.iter().enumerate() {
            let pts: Vec<(f64, f64)> = s
                .points
                .iter()
                .filter(|p| plottable(p))
                .map(|&(x, y)| (axes.px(x), axes.py(y)))
                .collect();
            for w in pts.windows(2) {
                line(img, w[0], w[1], s.color, 2);
            }
            for &(x, y) in &pts {
                for dy in -3..=3 {
                    for dx in -3..=3 {
                        put(img, x as i64 + dx, y as i64 + dy, s.color);
                    }
                }
            }
            let ly = TOP + 10 + 24 * k as i64;
            let lx = width as i64 - legend_w;
            line(
                img,
                (lx as f64, ly as f64 + 7.0),
                (lx as f64 + 30.0, ly as f64 + 7.0),
                s.color,
                3,
            );
            text(img, lx + 38, ly, &s.name, BLACK);
        }
    }
}

/// A grouped bar chart: for each group (a view, say) one bar per series (a part of an error
/// budget), heights on a linear axis from 0.
#[derive(Clone, Debug)]
pub struct Bars {
    pub title: String,
    pub y_label: String,
    pub groups: Vec<String>,
    /// Name, colour and one value per group (non-finite or negative values draw no bar).
    pub series: Vec<(String, [u8; 3], Vec<f64>)>,
}

impl Bars {
    pub fn draw(&self, width: u32, height: u32) -> RgbImage {
        let mut img = RgbImage::from_pixel(width, height, Rgb([255, 255, 255]));
        text(&mut img, LEFT, 10, &self.title, BLACK);
        text(&mut img, 8, Y_LABEL, &self.y_label, BLACK);
        let legend_w = self
            .series
            .iter()
            .map(|s| text_width(&s.0))
            .max()
            .unwrap_or(0)
            + 50;
        let (x0, x1) = (LEFT as f64, width as f64 - legend_w as f64 - 20.0);
        let (y0, y1) = (height as f64 - BOTTOM as f64, TOP as f64);
        let top = self
            .series
            .iter()
            .flat_map(|s| s.2.iter().copied())
            .filter(|v| v.is_finite())
            .fold(0.0f64, f64::max);
        if top <= 0.0 || self.groups.is_empty() {
            return img;
        }
        // A round step (1, 2 or 5 times a power of ten) giving four to ten grid lines.
        let magnitude = 10f64.powf((top / 5.0).log10().floor());
        let step = [1.0, 2.0, 5.0, 10.0]
            .iter()
            .map(|m| m * magnitude)
            .find(|st| top / st <= 10.0)
            .unwrap_or(10.0 * magnitude);
        let axis_top = (top / step).ceil() * step;
        let py = |v: f64| y0 + (y1 - y0) * v / axis_top;
        let mut v = 0.0;
        while v <= axis_top * (1.0 + 1e-9) {
            line(&mut img, (x0, py(v)), (x1, py(v)), [225, 225, 225], 1);
            let l = label(v);
            text(
                &mut img,
                LEFT - 8 - text_width(&l),
                py(v) as i64 - 7,
                &l,
                BLACK,
            );
            v += step;
        }
        line(&mut img, (x0, y0), (x1, y0), BLACK, 1);
        line(&mut img, (x0, y0), (x0, y1), BLACK, 1);
        let group_w = (x1 - x0) / self.groups.len() as f64;
        let bar_w = group_w * 0.8 / self.series.len().max(1) as f64;
        for (g, name) in self.groups.iter().enumerate() {
            let gx = x0 + group_w * g as f64 + group_w * 0.1;
            for (k, (_, color, values)) in self.series.iter().enumerate() {
                let Some(&v) = values.get(g).filter(|v| v.is_finite() && **v > 0.0) else {
                    continue;
                };
                let (bx0, bx1) = (gx + bar_w * k as f64, gx + bar_w * (k as f64 + 0.85));
                for y in (py(v).round() as i64)..(y0 as i64) {
                    line(&mut img, (bx0, y as f64), (bx1, y as f64), *color, 1);
                }
            }
            let centre = (x0 + group_w * (g as f64 + 0.5)) as i64;
            // As many lines as the bottom margin holds, each as wide as the group.
            let lines = wrap(name, group_w as i64);
            for (k, l) in lines.iter().take(((BOTTOM - 10) / 15) as usize).enumerate() {
                text(
                    &mut img,
                    centre - text_width(l) / 2,
                    y0 as i64 + 10 + 15 * k as i64,
                    l,
                    BLACK,
                );
            }
        }
        for (k, (name, color, _)) in self.series.iter().enumerate() {
            let (lx, ly) = (x1 as i64 + 20, TOP + 24 * k as i64);
            for dy in 0..14 {
                line(
                    &mut img,
                    (lx as f64, (ly + dy) as f64),
                    (lx as f64 + 30.0, (ly + dy) as f64),
                    *color,
                    1,
                );
            }
            text(&mut img, lx + 38, ly, name, BLACK);
        }
        img
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Labels break at spaces into lines that fit, a word too wide for any standing alone.
    #[test]
    fn labels_wrap_at_spaces_to_the_width() {
        let w = text_width;
        assert_eq!(wrap("mesh 1 spp", w("mesh 1 spp")), ["mesh 1 spp"]);
        assert_eq!(
            wrap("hybrid 1 spp, switch 0.5", w("hybrid 1")),
            ["hybrid 1", "spp,", "switch", "0.5"]
        );
        assert_eq!(wrap("overlong", w("over")), ["overlong"]);
        assert!(wrap("", 100).is_empty());
    }

    #[test]
    fn series_land_where_their_values_say_on_log_axes() {
        let plot = Plot {
            title: "t".into(),
            x_label: "seconds".into(),
            y_label: "rmse".into(),
            series: vec![Series {
                name: "a".into(),
                color: [255, 0, 0],
                points: vec![(1.0, 0.01), (10.0, 0.001), (f64::NAN, 1.0), (-1.0, 1.0)],
            }],
        };
        let img = plot.draw(600, 400);
        // Decades 1..10 across, 0.001..0.01 down: (1, 0.01) is the plot area's top-left corner,
        // (10, 0.001) its bottom-right, and the line between them passes the middle.
        let red = |x: u32, y: u32| img.get_pixel(x, y).0 == [255, 0, 0];
        let (x0, x1, y0, y1) = (90.0, 600.0 - (6.0 * 2.0 + 50.0) - 20.0, 330.0, 50.0);
        assert!(red(x0 as u32, y1 as u32));
        assert!(red(x1 as u32, y0 as u32));
        assert!(red(((x0 + x1) / 2.0) as u32, ((y0 + y1) / 2.0) as u32));
        assert_eq!(label(0.001), "0.001");
        assert_eq!(label(20.0), "20");
    }

    #[test]
    fn bars_rise_in_proportion_to_their_values() {
        let bars = Bars {
            title: "t".into(),
            y_label: "rmse".into(),
            groups: vec!["far".into(), "near".into()],
            series: vec![
                ("a".into(), [255, 0, 0], vec![1.0, 2.0]),
                ("b".into(), [0, 0, 255], vec![f64::NAN, 0.5]),
            ],
        };
        let img = bars.draw(600, 400);
        let height_of =
            |x: u32, c: [u8; 3]| (0..400).filter(|&y| img.get_pixel(x, y).0 == c).count();
        // Groups of (600 - 62 - 20 - 90) / 2 = 214 px; bars 0.8 x 214 / 2 wide, from 10 % in.
        let (x0, group, bar) = (90.0, 214.0, 85.6);
        let mid = |g: f64, k: f64| (x0 + group * g + group * 0.1 + bar * (k + 0.4)) as u32;
        let (a_far, a_near, b_near) = (
            height_of(mid(0.0, 0.0), [255, 0, 0]),
            height_of(mid(1.0, 0.0), [255, 0, 0]),
            height_of(mid(1.0, 1.0), [0, 0, 255]),
        );
        assert!(
            (a_near as f64 / a_far as f64 - 2.0).abs() < 0.02,
            "{a_far} {a_near}"
        );
        assert!(
            (a_near as f64 / b_near as f64 - 4.0).abs() < 0.05,
            "{b_near}"
        );
        assert_eq!(height_of(mid(0.0, 1.0), [0, 0, 255]), 0);
    }
}
