//! Writes the procedural fixtures: `cargo run --release --example make_fixtures -- fixtures`.

fn main() -> anyhow::Result<()> {
    let dir =
        std::path::PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "fixtures".into()));
    for (name, bytes) in texel_forest::procedural::fixture_files() {
        let path = dir.join(&name);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)?;
        }
        texel_forest::output::write_atomic(&path, &bytes)?;
        println!("{} ({} bytes)", path.display(), bytes.len());
    }
    let golden = dir.join("formats/conifer-8.texel");
    std::fs::create_dir_all(dir.join("formats"))?;
    let bytes = texel_forest::procedural::golden_texel(&dir.join("trees/conifer.glb"))?;
    texel_forest::output::write_atomic(&golden, &bytes)?;
    println!("{} ({} bytes)", golden.display(), bytes.len());
    let golden = dir.join("formats/forest-12.instances");
    let instances = texel_forest::procedural::golden_instances()?;
    texel_forest::output::write_atomic(&golden, &instances)?;
    println!("{} ({} bytes)", golden.display(), instances.len());
    let golden = dir.join("formats/forest-12-heightmap.instances");
    let bytes = texel_forest::procedural::golden_heightmap_instances()?;
    texel_forest::output::write_atomic(&golden, &bytes)?;
    println!("{} ({} bytes)", golden.display(), bytes.len());
    // The invalid corpus is rewritten whole, so a file dropped from the generator goes too.
    let invalid = dir.join("formats/invalid");
    if invalid.exists() {
        std::fs::remove_dir_all(&invalid)?;
    }
    std::fs::create_dir_all(&invalid)?;
    let files = texel_forest::procedural::invalid::invalid_files(&instances);
    for f in &files {
        texel_forest::output::write_atomic(&invalid.join(&f.name), &f.bytes)?;
    }
    println!("{} ({} files)", invalid.display(), files.len());
    Ok(())
}
