fn main() {
    let p = std::env::args().nth(1).unwrap();
    let data = std::fs::read(&p).unwrap();
    let r = texel_forest::import::load_bytes(
        std::path::Path::new("/nonexistent/fuzz.gltf"),
        data,
        &Default::default(),
    );
    match r {
        Ok(m) => {
            println!("ok {} tris", m.mesh.triangles.len());
            if !m.mesh.triangles.is_empty() {
                let s = texel_forest::bake::BakeSettings {
                    resolution: 8,
                    fine: 16,
                    ..Default::default()
                };
                println!(
                    "{:?}",
                    texel_forest::bake::bake(&m.mesh, &s)
                        .map(|_| ())
                        .map_err(|e| e.to_string())
                );
            }
        }
        Err(e) => println!("err {e}"),
    }
}
