//! The meshoptimizer peer of `gregvox bench --suite simplify` (meshopt crate, a dev-dependency):
//! reduces a mesh to each ratio with `meshopt_simplify` as its users call it (positions only, no error
//! limit so the triangle target decides), on one thread (meshoptimizer has no threaded simplifier), and
//! prints one JSON line per ratio; with `--out DIR` it writes each result as `DIR/meshopt_<ratio>.obj`
//! for the quality measurement.
//!
//! ```text
//! cargo run --release --example meshopt_peer -- MESH.obj 0.5,0.1,0.01 [--out DIR] [--repeat N]
//! ```
use gregvox::api::load_mesh;
use std::io::Write;
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(path), Some(ratios)) = (args.first(), args.get(1)) else {
        anyhow::bail!("usage: meshopt_peer MESH 0.5,0.1 [--out DIR] [--repeat N]");
    };
    let flag = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let out = flag("--out");
    let repeat: usize = flag("--repeat").map_or(Ok(1), |r| r.parse())?;
    let mesh = load_mesh(path)?;
    let positions: Vec<[f32; 3]> = mesh
        .positions
        .iter()
        .map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect();
    let mut indices = Vec::new();
    for f in 0..mesh.n_faces() {
        let face = mesh.face(f);
        for k in 1..face.len() - 1 {
            indices.extend_from_slice(&[face[0], face[k], face[k + 1]]);
        }
    }
    let adapter = meshopt::VertexDataAdapter::new(bytemuck::cast_slice(&positions), 12, 0)?;
    for r in ratios.split(',') {
        let ratio: f64 = r.parse()?;
        let target = ((indices.len() / 3) as f64 * ratio) as usize * 3;
        let mut best = f64::INFINITY;
        let mut result = Vec::new();
        let mut error = 0.0f32;
        for _ in 0..repeat.max(1) {
            let t = Instant::now();
            result = meshopt::simplify(
                &indices,
                &adapter,
                target,
                f32::MAX,
                meshopt::SimplifyOptions::None,
                Some(&mut error),
            );
            best = best.min(t.elapsed().as_secs_f64());
        }
        if let Some(dir) = &out {
            let file = std::path::Path::new(dir).join(format!("meshopt_{r}.obj"));
            let mut w = std::io::BufWriter::new(std::fs::File::create(&file)?);
            for p in &positions {
                writeln!(w, "v {} {} {}", p[0], p[1], p[2])?;
            }
            for t in result.chunks(3) {
                writeln!(w, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
            }
        }
        println!(
            "{}",
            serde_json::json!({
                "peer": "meshoptimizer",
                "ratio": ratio,
                "input_faces": indices.len() / 3,
                "faces": result.len() / 3,
                "seconds": best,
                "relative_error": error,
                "threads": 1,
            })
        );
    }
    Ok(())
}
