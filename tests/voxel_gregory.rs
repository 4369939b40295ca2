//! Specification of `--gregory-level`: a Gregory surface voxelized straight from its device-local vertex
//! buffer equals the CPU scanline of the same triangles (read back only for the check), in the frame of the
//! surface's bounding box found on the GPU.
mod common;

use common::{model, with_gpu};
use gregvox::engine::cage::cage_topology;
use gregvox::engine::gregory::GregorySurface;
use gregvox::engine::voxelize::voxelize_gregory_surface;
use gregvox::mesh::load_obj;
use gregvox::passes::gregory_eval::{grid_indices, SurfaceVertex};
use gregvox::surface::Tangents;
use gregvox::voxel::cpu::{voxelize_cpu, FillRule};
use gregvox::voxel::grid::{Axis, GridFrame};
use gregvox::voxel::mesh::TriMesh;

#[test]
fn the_gpu_surface_voxelizes_like_the_cpu_scanline_of_the_same_triangles() {
    let mesh = load_obj(model("spot_quadrangulated.obj")).unwrap();
    let (topo, cage, _) = cage_topology(&mesh, Tangents::OpenSubdiv).unwrap();
    let (level, res) = (4, 64);
    let (grid, layers, verts) = with_gpu(|ctx| {
        let s = GregorySurface::new(ctx, &topo, &cage, level).unwrap();
        ctx.one_shot(|cmd| s.record(ctx, cmd, None, None)).unwrap();
        let (g, stats) = voxelize_gregory_surface(
            ctx,
            &s,
            &gregvox::voxel::grid::GridSpec::res(res),
            &[Axis::Z],
            FillRule::Winding,
            64,
            None,
        )
        .unwrap();
        let v: Vec<SurfaceVertex> = s.read_vertices(ctx).unwrap();
        (g, stats[0].layers, v)
    });
    let tri = TriMesh {
        positions: verts
            .iter()
            .map(|v| [v.position[0], v.position[1], v.position[2]])
            .collect(),
        triangles: grid_indices(topo.patch_points.len() as u32, level)
            .chunks(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect(),
    };
    let frame = GridFrame::from_points(&tri.positions, res).unwrap();
    assert_eq!(
        grid.frame, frame,
        "the GPU bounds equal the CPU bounds of the same floats"
    );
    let cpu = voxelize_cpu(&tri, &frame, Axis::Z, FillRule::Winding);
    let diff = grid.count_differences(&cpu);
    eprintln!(
        "spot Gregory surface L={level} at {res}³: {} solid, {layers} layers, GPU vs CPU {diff}",
        cpu.count()
    );
    assert!(cpu.count() > 30_000);
    assert_eq!(
        layers % 2,
        0,
        "a closed surface crosses each column an even number of times"
    );
    common::assert_same_up_to_snapping(&grid, &cpu, &tri, "spot Gregory surface");
}

#[test]
fn the_cli_voxelizes_a_cage_surface_and_rejects_other_methods() {
    let out = std::env::temp_dir().join(format!("gregvox-gregory-{}.binvox", std::process::id()));
    let run = |extra: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_gregvox"))
            .args([
                "voxelize",
                &model("opensubdiv/catmark_cube.obj").to_string_lossy(),
                "--res",
                "24",
                "--gregory-level",
                "6",
            ])
            .args(extra)
            .env("GREGVOX_VALIDATION", "1")
            .output()
            .unwrap()
    };
    let ok = run(&["--out", out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&ok.stderr);
    assert!(
        ok.status.success() && !err.contains("vulkan validation"),
        "{err}"
    );
    let g = gregvox::voxel::export::parse_binvox(&std::fs::read(&out).unwrap()).unwrap();
    // The ACC-2 surface of the cube is a rounded box inside the cage: most of the grid, not all of it.
    let fill = g.count() as f64 / 24f64.powi(3);
    assert!(fill > 0.4 && fill < 0.95, "{fill}");
    let _ = std::fs::remove_file(&out);
    let bad = run(&["--method", "cpu"]);
    assert_eq!(bad.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--method peel"));
}
