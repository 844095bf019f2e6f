//! The trees of a forest as a table, one row per tree in the forest's order: position of the
//! base of the trunk (m), rotation about +Y (degrees, counter-clockwise seen from above: the
//! renderer's turn), scale (from the model's units), height (m), species name and the
//! per-tree variation. Numbers are written with fixed decimals, so the same forest gives the
//! same bytes.

use serde_json::json;

use crate::formats::instances::Forest;

/// The CSV header.
pub const CSV_HEADER: &str = "x,y,z,rotation_deg,scale,height_m,species,variation";

/// One tree's values, rounded as written.
struct Row<'a> {
    position: [f64; 3],
    rotation_deg: f64,
    scale: f64,
    height: f64,
    species: &'a str,
    variation: u16,
}

/// `v` rounded to `decimals` places (the number its fixed-decimal text reads as).
fn rounded(v: f64, decimals: i32) -> f64 {
    let f = 10f64.powi(decimals);
    let r = (v * f).round() / f;
    if r == 0.0 { 0.0 } else { r }
}

fn rows(forest: &Forest) -> impl Iterator<Item = Row<'_>> {
    forest.instances.iter().map(|t| {
        let s = &forest.info.species[t.species as usize];
        Row {
            position: t.position.map(|c| rounded(c, 2)),
            rotation_deg: rounded(f64::from(t.rotation).to_degrees(), 3),
            scale: rounded(f64::from(t.scale), 6),
            height: rounded(f64::from(t.scale) * s.model_height, 3),
            species: &s.name,
            variation: t.variation,
        }
    })
}

/// A CSV field, quoted where it holds a comma, a quote or a line break (RFC 4180).
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The trees as CSV: [`CSV_HEADER`], then one line per tree.
pub fn csv(forest: &Forest) -> String {
    let mut out = String::from(CSV_HEADER);
    out.push('\n');
    for r in rows(forest) {
        let [x, y, z] = r.position;
        out.push_str(&format!(
            "{x:.2},{y:.2},{z:.2},{:.3},{:.6},{:.3},{},{}\n",
            r.rotation_deg,
            r.scale,
            r.height,
            field(r.species),
            r.variation
        ));
    }
    out
}

/// The trees as JSON: `{"units": ..., "trees": [{"position", "rotation_deg", "scale",
/// "height_m", "species", "variation"}, ...]}`.
pub fn json_table(forest: &Forest) -> String {
    let trees: Vec<serde_json::Value> = rows(forest)
        .map(|r| {
            json!({
                "position": r.position,
                "rotation_deg": r.rotation_deg,
                "scale": r.scale,
                "height_m": r.height,
                "species": r.species,
                "variation": r.variation,
            })
        })
        .collect();
    let table = json!({
        "units": {
            "position": "metres, base of the trunk, +Y up",
            "rotation_deg": "degrees about +Y, counter-clockwise seen from above",
            "height_m": "metres",
        },
        "trees": trees,
    });
    let mut text = serde_json::to_string_pretty(&table).expect("JSON values serialise");
    text.push('\n');
    text
}
