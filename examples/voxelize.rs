//! Voxelize a mesh file to a chosen format.
//!
//!     cargo run --release --example voxelize -- assets/models/stanford-bunny.obj 128 bunny.binvox
//!
//! The output format comes from the extension: .binvox, .npy, .nrrd, .raw (+ .json sidecar) or .vox.
//! With `cpu` as a fourth argument the CPU scanline runs instead of the GPU (no Vulkan needed).
use gregvox::{load_mesh, voxelize_on_cpu, Gpu, Method, VoxelizeOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [input, res, output, rest @ ..] = args.as_slice() else {
        return Err("usage: voxelize IN.obj RES OUT.{binvox,npy,nrrd,raw,vox} [cpu]".into());
    };
    let mesh = load_mesh(input)?;
    let opts = VoxelizeOptions::default().res(res.parse()?);
    let voxels = if rest.first().map(String::as_str) == Some("cpu") {
        voxelize_on_cpu(&mesh, &opts.method(Method::Cpu))?
    } else {
        let gpu = Gpu::new()?;
        println!("device: {}", gpu.info().name);
        let voxels = gpu.voxelize(&mesh, &opts)?;
        gpu.finish()?; // nothing left alive, no validation message
        voxels
    };
    for note in &voxels.report.notes {
        println!("note: {note}");
    }
    voxels.grid.save(output)?;
    println!(
        "{input}: {} triangles, {} solid voxels of {}³, written to {output}",
        voxels.report.triangles,
        voxels.grid.count(),
        voxels.report.res
    );
    Ok(())
}
