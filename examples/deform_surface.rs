//! Build a Gregory surface from a quad cage, deform it for a few frames on the GPU and read the vertices back.
//!
//!     cargo run --release --example deform_surface -- assets/models/spot_quadrangulated.obj 8
use gregvox::{load_mesh, Deformation, Gpu};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .unwrap_or_else(|| "assets/models/spot_quadrangulated.obj".into());
    let level: u32 = args.next().map(|l| l.parse()).transpose()?.unwrap_or(8);
    let gpu = Gpu::new()?;
    let cage = load_mesh(&path)?;
    let mut surface = gpu.gregory_surface(&cage, level)?;
    if let Some(note) = surface.note() {
        println!("note: {note}");
    }
    println!(
        "{path}: {} patches at level {level} on {}",
        surface.patch_count(),
        gpu.info().name
    );
    for frame in 0..5 {
        let t = frame as f32 / 5.0;
        // The cage moves on the GPU; W·cage and the patch evaluation follow in the same submission.
        surface.deform(Deformation::Twist, t, 0.3)?;
        let vertices = surface.read_vertices()?;
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for v in &vertices {
            for a in 0..3 {
                lo[a] = lo[a].min(v.position[a]);
                hi[a] = hi[a].max(v.position[a]);
            }
        }
        let unit = vertices
            .iter()
            .all(|v| (glam::Vec3::from_slice(&v.normal[..3]).length() - 1.0).abs() < 1e-3);
        println!(
            "t = {t:.1}: {} vertices, box {lo:.3?} … {hi:.3?}, unit normals: {unit}",
            vertices.len()
        );
    }
    drop(surface);
    gpu.finish()?; // nothing left alive, no validation message
    Ok(())
}
