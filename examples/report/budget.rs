//! The error budget: the texel method's error against the mesh reference, split into the
//! parts its approximations cause, each measured by rendering both methods with the rest
//! switched off, so every change to the method can name the part it cuts and by how much.
//!
//! - **coverage**: the trees' alpha alone (`canopy.A` of both), in alpha units: silhouettes,
//!   crown density, mip levels;
//! - **shading**: colour with shadows switched off in both (`--no-shadows`): normals, the
//!   phase function, albedo mixing, and coverage's effect on colour;
//! - **shadows**: the error of what shadows take away, `(T - T_unshadowed) - (M -
//!   M_unshadowed)`: self-shadowing inside crowns, shadow mip levels, shadows on the ground;
//! - **noise**: the spread over seeds, `rms(T_seed0 - T_seed1) / sqrt 2`.
//!
//! Beside them, what one sample per pixel makes of it (the speed-against-error curves' first
//! point): the total of a 1-spp render (the default settings, its outline rendered again),
//! and the total at 16 spp reading the levels a 1-spp render reads (`--lod-bias 2`: each
//! sample's level matched to the whole pixel's footprint, not its sixteenth's), which is what
//! that render would be with its noise and aliasing gone, and so bounds what any change to
//! its sampling could gain.
//!
//! Also the total again with exact shadow rays (`--shadows exact`, a jittered march
//! per tree, where the default reads the sun-depth cache): what the cache adds to the error,
//! or takes from it (it has no noise of its own, nor the brightening exp(-depth) takes from a
//! noisy depth).
//!
//! The parts are RMSEs over the frame, so they do not add up to the total; each bounds what
//! removing its cause alone could gain. The bias on tree pixels (where the reference's canopy
//! is above one half) is given as mean ratios per channel, as `texel compare --mask REF.exr
//! --mask-channel canopy.A` reports them.

use std::fmt::Write as _;
use std::path::Path;

use texel_forest::compare::{Rgba, block_mask, compare};
use texel_forest::plot::{Bars, PALETTE};

use crate::{Report, VIEWS, View};

/// Pixels on a side of the blocks the tree mask is decided in.
const TREE_BLOCK: usize = 4;

/// Samples per pixel of the texel renders the budget measures (their noise is its own part).
pub const BUDGET_SPP: u32 = 16;

/// One view's budget (RMSEs; coverage in alpha, the rest in radiance).
pub struct Budget {
    pub view: &'static str,
    pub total: f64,
    /// The total with exact shadow rays.
    pub total_exact_shadows: f64,
    /// The total of a 1-spp render.
    pub one_spp: f64,
    /// The total at [`BUDGET_SPP`] with the levels a 1-spp render reads.
    pub one_spp_levels: f64,
    pub coverage: f64,
    pub shading: f64,
    pub shadows: f64,
    pub noise: f64,
    /// Texel over mesh mean radiance on tree pixels, per channel.
    pub ratio: [Option<f64>; 3],
    /// Texel over mesh mean canopy alpha over the frame: how much wider the crowns are.
    pub canopy_ratio: f64,
    pub tree_pixels: usize,
}

/// Root mean square over pixels and colour channels of `f(pixel, channel)`.
fn rms(pixels: usize, f: impl Fn(usize, usize) -> f64) -> f64 {
    let sum: f64 = (0..pixels)
        .flat_map(|i| (0..3).map(move |c| (i, c)))
        .map(|(i, c)| f(i, c).powi(2))
        .sum();
    (sum / (3 * pixels.max(1)) as f64).sqrt()
}

fn read(path: &Path) -> Rgba {
    Rgba::read(path, &Default::default()).unwrap()
}

fn canopy(path: &Path) -> Vec<f32> {
    Rgba::read_channels(path, ["canopy.A"; 4], &Default::default())
        .unwrap()
        .pixels
        .iter()
        .map(|p| p[0])
        .collect()
}

impl Report {
    /// The budget of the texel method at [`BUDGET_SPP`] on `forest` from `view`.
    pub fn budget(&self, forest: &str, view: &View<'static>) -> Budget {
        eprintln!("report: error budget of the {} view...", view.name);
        let reference = self.reference(forest, view, &[]);
        let unshadowed_reference = self.reference(forest, view, &["--no-shadows"]);
        let spp = BUDGET_SPP.to_string();
        let out = |tag: &str| format!("budget-{}-{tag}.exr", view.name);
        let texel = |tag: &str, extra: &[&str]| {
            let mut flags = vec!["--method", "texel", "--aov", "canopy"];
            flags.extend_from_slice(extra);
            self.render(forest, view, &flags, &out(tag));
            self.work.join(out(tag))
        };
        let texel_budget =
            |tag: &str, extra: &[&str]| texel(tag, &[&["--spp", spp.as_str()], extra].concat());
        let t = texel_budget("full", &[]);
        let t_seed = texel_budget("seed1", &["--seed", "1"]);
        let t_unshadowed = texel_budget("unshadowed", &["--no-shadows"]);
        let t_exact = texel_budget("exact-shadows", &["--shadows", "exact"]);
        let t_one = texel("1spp", &[]);
        // Sixteen samples' footprints are a quarter of the pixel's across: two levels up.
        let t_one_levels = texel_budget("1spp-levels", &["--lod-bias", "2"]);
        let (m, mn) = (read(&reference), read(&unshadowed_reference));
        let (tf, ts, tn) = (read(&t), read(&t_seed), read(&t_unshadowed));
        let n = m.pixels.len();
        let value = |img: &Rgba, i: usize, c: usize| f64::from(img.pixels[i][c]);
        let (canopy_t, canopy_m) = (canopy(&t), canopy(&reference));
        // Tree pixels decided in blocks (`texel compare --mask-block`): the reference's own
        // matte would favour its sharper silhouettes.
        let trees: Vec<bool> = canopy_m.iter().map(|&a| a > 0.5).collect();
        let trees = block_mask(&trees, (m.width, m.height), TREE_BLOCK);
        let on_trees = compare(&tf, &m, |i| trees[i]);
        Budget {
            view: view.name,
            total: compare(&tf, &m, |_| true).rgb.rmse,
            total_exact_shadows: compare(&read(&t_exact), &m, |_| true).rgb.rmse,
            one_spp: compare(&read(&t_one), &m, |_| true).rgb.rmse,
            one_spp_levels: compare(&read(&t_one_levels), &m, |_| true).rgb.rmse,
            coverage: (canopy_t
                .iter()
                .zip(&canopy_m)
                .map(|(a, b)| f64::from(a - b).powi(2))
                .sum::<f64>()
                / n as f64)
                .sqrt(),
            shading: compare(&tn, &mn, |_| true).rgb.rmse,
            shadows: rms(n, |i, c| {
                (value(&tf, i, c) - value(&tn, i, c)) - (value(&m, i, c) - value(&mn, i, c))
            }),
            noise: rms(n, |i, c| value(&tf, i, c) - value(&ts, i, c)) / 2f64.sqrt(),
            ratio: on_trees.mean_ratio,
            canopy_ratio: canopy_t.iter().map(|&a| f64::from(a)).sum::<f64>()
                / canopy_m
                    .iter()
                    .map(|&a| f64::from(a))
                    .sum::<f64>()
                    .max(1e-12),
            tree_pixels: on_trees.pixels,
        }
    }
}

/// The parts as they are drawn and tabulated: name and value.
fn parts(b: &Budget) -> [(&'static str, f64); 5] {
    [
        ("total", b.total),
        ("coverage (alpha)", b.coverage),
        ("shading, unshadowed", b.shading),
        ("shadows", b.shadows),
        ("noise", b.noise),
    ]
}

/// The budgets as a Markdown section (also written alone to `error_budget.md`), a CSV and a
/// bar chart, under `dir`.
pub fn write(dir: &Path, budgets: &[Budget]) -> String {
    let mut md = format!(
        "## Error budget (texel method, {BUDGET_SPP} spp, against the mesh reference)\n\n\
         Each part is the RMSE with the rest switched off (see `examples/report/budget.rs`); \
         coverage is in alpha, the rest in radiance. Ratios: texel over mesh mean radiance on \
         tree pixels (reference canopy above one half, decided in blocks of 4 x 4 pixels). \
         The total with exact shadow rays (`--shadows exact`) in place of the sun-depth cache, \
         and what the cache changes, come next; last, the total of a 1-spp render, and at \
         {BUDGET_SPP} spp with the levels a 1-spp render reads (`--lod-bias 2`): that render \
         with its noise and aliasing gone.\n\n\
         | view | total | coverage (alpha) | canopy ratio | shading, unshadowed | shadows | noise | ratio R / G / B on trees | total, exact shadows | cache's change | 1 spp | 1 spp's levels, {BUDGET_SPP} spp |\n\
         |---|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|\n"
    );
    let mut csv = String::from(
        "view,total,coverage,canopy_ratio,shading,shadows,noise,ratio_r,ratio_g,ratio_b,tree_pixels,total_exact_shadows,one_spp,one_spp_levels\n",
    );
    let ratio = |r: Option<f64>| r.map_or("-".to_string(), |r| format!("{r:.3}"));
    for b in budgets {
        let p = parts(b);
        writeln!(
            md,
            "| {} | {:.5} | {:.5} | {:.3} | {:.5} | {:.5} | {:.5} | {} / {} / {} | {:.5} | {:+.1}% | {:.5} | {:.5} |",
            b.view,
            p[0].1,
            p[1].1,
            b.canopy_ratio,
            p[2].1,
            p[3].1,
            p[4].1,
            ratio(b.ratio[0]),
            ratio(b.ratio[1]),
            ratio(b.ratio[2]),
            b.total_exact_shadows,
            100.0 * (b.total / b.total_exact_shadows - 1.0),
            b.one_spp,
            b.one_spp_levels
        )
        .unwrap();
        writeln!(
            csv,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            b.view,
            p[0].1,
            p[1].1,
            b.canopy_ratio,
            p[2].1,
            p[3].1,
            p[4].1,
            ratio(b.ratio[0]),
            ratio(b.ratio[1]),
            ratio(b.ratio[2]),
            b.tree_pixels,
            b.total_exact_shadows,
            b.one_spp,
            b.one_spp_levels
        )
        .unwrap();
    }
    md += "\n![error budget](error_budget.png)\n";
    let bars = Bars {
        title: format!(
            "texel method's error by part, {BUDGET_SPP} spp, against the mesh reference"
        ),
        y_label: "RMSE".into(),
        groups: budgets.iter().map(|b| b.view.to_string()).collect(),
        series: (0..5)
            .map(|k| {
                let name = parts(&budgets[0])[k].0.to_string();
                (
                    name,
                    PALETTE[k],
                    budgets.iter().map(|b| parts(b)[k].1).collect(),
                )
            })
            .collect(),
    };
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("error_budget.csv"), csv).unwrap();
    std::fs::write(dir.join("error_budget.md"), &md).unwrap();
    std::fs::write(
        dir.join("error_budget.png"),
        texel_forest::png::encode(&bars.draw(900, 420)),
    )
    .unwrap();
    md
}

/// The budget of every view on `forest`, written under `dir`; returns its Markdown.
pub fn run(report: &Report, forest: &str, dir: &Path) -> String {
    let budgets: Vec<Budget> = VIEWS.iter().map(|v| report.budget(forest, v)).collect();
    write(dir, &budgets)
}
