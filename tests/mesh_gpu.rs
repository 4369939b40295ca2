//! Specification of the GPU half of the mesh matrices: action-mapped gather products for vertex normals
//! (against libigl's AREA normals and the CPU), and subdivision as one SpMV per level (against the CPU).
mod common;
mod mesh_common;

use ash::vk;
use common::with_gpu;
use glam::DVec3;
use gregvox::gpu::{Buffer, Context, MemoryLocation};
use gregvox::mesh::{load_obj, MeshMatrix, NormalWeighting, SubdivisionStack};
use gregvox::passes::mesh_normals::{GpuMeshMatrix, MeshNormalsPass};
use gregvox::passes::spmv::{GpuSparse, SpmvPass};
use mesh_common::{model, read_f64x3};

fn vec4_buffer(ctx: &Context, name: &str, p: &[DVec3]) -> Buffer {
    let data: Vec<[f32; 4]> = p
        .iter()
        .map(|v| [v.x as f32, v.y as f32, v.z as f32, 1.0])
        .collect();
    ctx.upload_buffer(
        name,
        bytemuck::cast_slice(&data),
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
    )
    .unwrap()
}

fn gpu_normals(m: &MeshMatrix, positions: &[DVec3]) -> Vec<DVec3> {
    with_gpu(|ctx| {
        let pass = MeshNormalsPass::new(ctx).unwrap();
        let gm = GpuMeshMatrix::upload(ctx, m).unwrap();
        let pb = vec4_buffer(ctx, "positions", positions);
        let out = ctx
            .create_buffer(
                "normals",
                positions.len() as u64 * 16,
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::GpuOnly,
            )
            .unwrap();
        ctx.one_shot(|cmd| pass.record(ctx, cmd, &gm, &pb, &out))
            .unwrap();
        let n: Vec<[f32; 4]> = ctx.read_pod(&out).unwrap();
        n.iter()
            .map(|v| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64))
            .collect()
    })
}

#[test]
fn gpu_area_normals_match_libigl_on_bunny_spot_and_cow() {
    // Tolerance 2e-5 per component (issue): f32 sums of a few dozen cross products of unit-scale vectors.
    for (name, fixture) in [
        ("stanford-bunny.obj", "stanford-bunny.normals_area.f64"),
        ("spot.obj", "spot.normals_area.f64"),
        ("cow.obj", "cow.normals_area.f64"),
    ] {
        let mesh = load_obj(model(name)).unwrap();
        let m = MeshMatrix::from_mesh(&mesh);
        let gpu = gpu_normals(&m, &mesh.positions);
        let oracle = read_f64x3(fixture);
        let cpu = m.vertex_normals(&mesh.positions, NormalWeighting::Area);
        let (mut worst, mut worst_cpu) = (0.0f64, 0.0f64);
        for v in 0..gpu.len() {
            assert!(gpu[v].is_finite());
            if m.is_referenced(v) {
                worst = worst.max((gpu[v] - oracle[v]).abs().max_element());
                worst_cpu = worst_cpu.max((gpu[v] - cpu[v]).abs().max_element());
            } else {
                assert_eq!(gpu[v], DVec3::ZERO, "{name}: unreferenced vertex {v}");
            }
        }
        eprintln!("{name}: GPU vs libigl {worst:.2e}, vs CPU f64 {worst_cpu:.2e}");
        assert!(worst <= 2e-5, "{name}: {worst}");
    }
}

#[test]
fn gpu_normals_follow_a_deformed_mesh() {
    let mesh = load_obj(model("spot.obj")).unwrap();
    let m = MeshMatrix::from_mesh(&mesh);
    // A smooth non-rigid deformation: the normals must be recomputed, not carried over.
    let moved: Vec<DVec3> = mesh
        .positions
        .iter()
        .map(|p| {
            DVec3::new(
                p.x * (1.0 + 0.3 * p.y),
                p.y + 0.2 * (3.0 * p.x).sin(),
                p.z * 0.7,
            )
        })
        .collect();
    let gpu = gpu_normals(&m, &moved);
    let cpu = m.vertex_normals(&moved, NormalWeighting::Area);
    let rest = m.vertex_normals(&mesh.positions, NormalWeighting::Area);
    let worst = gpu
        .iter()
        .zip(&cpu)
        .map(|(g, c)| (*g - *c).abs().max_element())
        .fold(0.0, f64::max);
    let moved_most = cpu
        .iter()
        .zip(&rest)
        .map(|(a, b)| (*a - *b).length())
        .fold(0.0, f64::max);
    assert!(worst <= 2e-5, "{worst}");
    assert!(
        moved_most > 0.1,
        "the deformation must change the normals (negative control): {moved_most}"
    );
}

#[test]
fn repeated_subdivision_is_one_gpu_spmv_per_level() {
    // spot_control_mesh twice: the GPU chain S2·(S1·P) equals the CPU chain within f32 rounding.
    let mesh = load_obj(model("spot_control_mesh.obj")).unwrap();
    let stack = SubdivisionStack::catmull_clark(&MeshMatrix::from_mesh(&mesh), 2);
    let cpu = stack.apply(&mesh.positions);
    let gpu = with_gpu(|ctx| {
        let pass = SpmvPass::new(ctx).unwrap();
        let mats: Vec<GpuSparse> = stack
            .levels
            .iter()
            .enumerate()
            .map(|(i, l)| GpuSparse::upload(ctx, &format!("S{i}"), &l.s).unwrap())
            .collect();
        let mut bufs = vec![vec4_buffer(ctx, "P0", &mesh.positions)];
        for (i, l) in stack.levels.iter().enumerate() {
            bufs.push(
                ctx.create_buffer(
                    &format!("P{}", i + 1),
                    l.s.n_rows as u64 * 16,
                    vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
                    MemoryLocation::GpuOnly,
                )
                .unwrap(),
            );
        }
        ctx.one_shot(|cmd| {
            for (i, a) in mats.iter().enumerate() {
                pass.record(ctx, cmd, a, &bufs[i], &bufs[i + 1])?;
            }
            Ok(())
        })
        .unwrap();
        ctx.read_pod::<[f32; 4]>(bufs.last().unwrap()).unwrap()
    });
    assert_eq!(gpu.len(), cpu.len());
    let diag = 2.0; // spot fits in about [-1, 1]³
    let worst = gpu
        .iter()
        .zip(&cpu)
        .map(|(g, c)| (DVec3::new(g[0] as f64, g[1] as f64, g[2] as f64) - *c).length())
        .fold(0.0, f64::max);
    eprintln!(
        "spot control mesh CC×2 on the GPU: {} vertices, max |Δ| {worst:.2e}",
        gpu.len()
    );
    assert!(worst < 1e-6 * diag * 4.0, "{worst}");
}
