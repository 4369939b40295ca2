//! Writes the generalized winding number's stress suite (`gregvox::voxel::stress`) as OBJ files into a
//! folder, with `index.json` naming each case, what it is, its triangle count and the FNV-1a hash of its
//! text: what `tests/oracle/gen_gwn_stress.py` reads to make the fixtures.
//!
//!     cargo run --release --example gwn_stress -- target/gwn-stress
use gregvox::api::load_mesh;
use gregvox::voxel::mesh::TriMesh;
use gregvox::voxel::stress::{fnv1a, obj_text, suite};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = PathBuf::from(std::env::args().nth(1).ok_or("usage: gwn_stress OUT_DIR")?);
    std::fs::create_dir_all(&out)?;
    let models = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/models");
    let bunny = TriMesh::fan(&load_mesh(models.join("stanford-bunny.obj"))?);
    let teapot = TriMesh::fan(&load_mesh(models.join("teapot.obj"))?);
    let mut index = Vec::new();
    for case in suite(&bunny, &teapot) {
        let text = obj_text(&case.mesh);
        let file = format!("{}.obj", case.name);
        std::fs::write(out.join(&file), &text)?;
        index.push(serde_json::json!({
            "name": case.name,
            "what": case.what,
            "file": file,
            "triangles": case.mesh.triangles.len(),
            "fnv1a": format!("{:016x}", fnv1a(text.as_bytes())),
        }));
        println!(
            "{}: {} triangles ({})",
            case.name,
            case.mesh.triangles.len(),
            case.what
        );
    }
    std::fs::write(
        out.join("index.json"),
        serde_json::to_string_pretty(&serde_json::json!({ "cases": index }))?,
    )?;
    Ok(())
}
