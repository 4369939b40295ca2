//! Print a mesh's topology from its mesh matrices (the oriented edge→face matrix E and the vertex×face
//! matrix M): closed?, manifold?, components, boundary loops, valences, Euler characteristic.
//!
//!     cargo run --example topology -- assets/models/stanford-bunny.obj
use gregvox::mesh::MeshMatrix;
use gregvox::{load_mesh, topology};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "assets/models/stanford-bunny.obj".into());
    let mesh = load_mesh(&path)?;
    let report = topology(&mesh);
    println!("{path}");
    println!("{}", serde_json::to_string_pretty(&report)?);
    // The matrices answer more than the report: the boundary loops, a vertex's neighbours and valence.
    let m = MeshMatrix::from_mesh(&mesh);
    let loops = m.boundary_loops();
    let longest = loops.iter().map(Vec::len).max().unwrap_or(0);
    println!(
        "{} boundary loops, the longest of {longest} edges",
        loops.len()
    );
    println!(
        "vertex 1: valence {}, neighbours {:?}",
        m.valence(0),
        m.neighbours(0)
    );
    Ok(())
}
