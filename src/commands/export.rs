//! `texel export`: `.instances` -> a glTF 2.0 (`.glb`, or `.gltf` text) of instanced tree
//! models, and tables of the trees (CSV, JSON).

use std::time::Instant;

use texel_forest::export;
use texel_forest::limits::Limits;
use texel_forest::output::{Outputs, depfile_for};

use crate::cli::ExportArgs;

pub fn run(args: &ExportArgs, limits: &Limits, quiet: bool) -> anyhow::Result<()> {
    let start = Instant::now();
    let mut outputs = Outputs::new(&[&args.instances]);
    let glb_out = args
        .output
        .as_ref()
        .map(|o| outputs.add("-o", o))
        .transpose()?;
    let csv_out = args
        .csv
        .as_ref()
        .map(|o| outputs.add("--csv", o))
        .transpose()?;
    let json_out = args
        .json
        .as_ref()
        .map(|o| outputs.add("--json", o))
        .transpose()?;
    let dep_out = args
        .depfile
        .as_ref()
        .map(|d| outputs.add("--depfile", d))
        .transpose()?;

    let has_glb = glb_out.is_some();
    let mut inputs = export::load(&args.instances, has_glb, args.with_terrain, limits)?;
    outputs.add_inputs(&inputs.dependencies)?;
    let mut summary = Vec::new();
    if let Some(id) = glb_out {
        let mut warnings = Vec::new();
        let container = args
            .output
            .as_deref()
            .map_or(export::Container::Glb, export::Container::for_path);
        let bytes = export::gltf(&mut inputs, container, &mut warnings)?;
        for w in &warnings {
            super::warn(w);
        }
        summary.push(format!("{} bytes of glTF", bytes.len()));
        outputs.set(id, bytes);
    }
    let files = inputs.files_read();
    outputs.add_inputs(&files[inputs.dependencies.len()..])?;
    if let Some(id) = csv_out {
        outputs.set(id, export::csv(&inputs.forest).into_bytes());
    }
    if let Some(id) = json_out {
        outputs.set(id, export::json_table(&inputs.forest).into_bytes());
    }
    if let Some(id) = dep_out {
        let targets: Vec<&std::path::Path> = [&args.output, &args.csv, &args.json]
            .into_iter()
            .flatten()
            .map(|p| p.as_path())
            .collect();
        outputs.set(id, depfile_for(&targets, &files)?.into_bytes());
    }
    outputs.commit()?;
    if !quiet {
        let written: Vec<String> = [&args.output, &args.csv, &args.json]
            .into_iter()
            .flatten()
            .map(|p| p.display().to_string())
            .collect();
        let n = inputs.forest.instances.len();
        let detail = if summary.is_empty() {
            String::new()
        } else {
            format!(" ({})", summary.join(", "))
        };
        super::summary(&format!(
            "exported {n} trees of {} species -> {}{detail}, in {:.2} s",
            inputs.forest.info.species.len(),
            written.join(", "),
            start.elapsed().as_secs_f64()
        ));
    }
    Ok(())
}
