//! Times `api::simplify` on the simplify bench's meshes (median of N calls per ratio) and writes each
//! mesh as OBJ so `examples/meshopt_peer.rs` can reduce the same input in the same session: the
//! profiling loop behind the `simplify` bench rows.
//!
//! ```text
//! cargo run --release --example simplify_profile -- DIR [--repeat N]
//! ```
use gregvox::api::{load_mesh, simplify, SimplifyOptions};
use gregvox::bench::simplify::{cad_block, voxel_surface};
use gregvox::voxel::mesh::TriMesh;
use std::time::Instant;

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
            let opts = SimplifyOptions {
                ratio: Some(ratio),
                ..Default::default()
            };
            let mut times = Vec::new();
            let mut last = None;
            for _ in 0..repeat {
                let t = Instant::now();
                let s = simplify(mesh, &opts)?;
                times.push(t.elapsed().as_secs_f64() * 1e3);
                last = Some(s);
            }
            times.sort_by(f64::total_cmp);
            let s = last.expect("one run");
            println!(
                "{name} {ratio}: {:.1} ms (min {:.1}), faces {}, passes {}, error {:.3e}",
                times[times.len() / 2],
                times[0],
                s.report.faces,
                s.report.passes,
                s.report.relative_error
            );
        }
    }
    Ok(())
}
