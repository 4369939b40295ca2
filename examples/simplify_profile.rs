//! Times `api::simplify` on the simplify bench's meshes (median of N calls per ratio) and writes each
//! mesh as OBJ so `examples/meshopt_peer.rs` can reduce the same input in the same session: the
//! profiling loop behind the `simplify` bench rows.
//!
//! ```text
//! cargo run --release --example simplify_profile -- DIR [--repeat N]
//! ```
use gregvox::api::load_mesh;
use gregvox::bench::simplify::{cad_block, timed_simplify, voxel_surface};
use gregvox::voxel::mesh::TriMesh;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = std::path::PathBuf::from(args.first().cloned().unwrap_or_else(|| ".".into()));
    let repeat: usize = args
        .iter()
        .position(|a| a == "--repeat")
        .and_then(|i| args.get(i + 1))
        .map_or(Ok(5), |r| r.parse())?;
    std::fs::create_dir_all(&dir)?;
    let bunny = load_mesh("assets/models/stanford-bunny.obj")?;
    let cases = [
        ("bunny", bunny.clone()),
        ("cad_block", cad_block(96, 256)),
        ("voxel96", voxel_surface(&TriMesh::fan(&bunny), 96)),
    ];
    for (name, mesh) in &cases {
        gregvox::mesh::write_obj(dir.join(format!("{name}.obj")), mesh)?;
        for ratio in [0.5, 0.1, 0.01] {
            let (ms, s) = timed_simplify(mesh, ratio, repeat)?;
            println!(
                "{name} {ratio}: {ms:.1} ms (median of {repeat}), faces {}, passes {}, error {:.3e}",
                s.report.faces, s.report.passes, s.report.relative_error
            );
        }
    }
    Ok(())
}
