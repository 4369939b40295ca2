//! Voxelize a mesh file to a chosen format.
//!
//!     cargo run --release --example voxelize -- assets/models/stanford-bunny.obj 128 bunny.binvox
//!
//! The output format comes from the extension: .binvox, .npy, .nrrd, .raw (+ .json sidecar) or .vox.
//! A fourth argument names the method: `auto` (the default: the CPU scanline on a CPU device such as
//! lavapipe, the A-buffer on a GPU), `peel`, `abuffer`, or `cpu` (no Vulkan needed).
use gregvox::{load_mesh, voxelize_on_cpu, Gpu, Method, VoxelizeOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [input, res, output, rest @ ..] = args.as_slice() else {
        return Err(
            "usage: voxelize IN RES OUT.{binvox,npy,nrrd,raw,vox} [auto|peel|abuffer|cpu]".into(),
        );
    };
    let mesh = load_mesh(input)?;
    let method = match rest.first().map(String::as_str) {
        None | Some("auto") => Method::Auto,
        Some("peel") => Method::Peel,
        Some("abuffer") => Method::Abuffer,
        Some("cpu") => Method::Cpu,
        Some(m) => return Err(format!("unknown method '{m}'").into()),
    };
    let opts = VoxelizeOptions::default().res(res.parse()?).method(method);
    let voxels = if method == Method::Cpu {
        voxelize_on_cpu(&mesh, &opts)?
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
        "{input}: {} triangles, {} solid voxels of {:?} by {}, written to {output}",
        voxels.report.triangles,
        voxels.grid.count(),
        voxels.grid.frame.dims,
        voxels.report.method.name()
    );
    Ok(())
}
