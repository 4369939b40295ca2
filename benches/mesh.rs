//! CPU mesh benchmarks: vertex normals (AREA) and one subdivision level on the Stanford bunny (69,451
//! triangles) and on the bunny refined to about 1 M faces: `bunny_loop2` (two Loop levels, Warren β:
//! 1,111,216 triangles, the same mesh size the peer script gives libigl and trimesh) and `bunny_cc2`
//! (two Catmull–Clark levels: 833,412 quads).
//! Run: `cargo bench --bench mesh`; peers: `python3 tests/oracle/bench_mesh_peers.py`.
//!
//! - `matrix`: build the MeshMatrix (M, Mᵀ, E, twins, edge ids) from loaded faces;
//! - `normals`: AREA vertex normals from a built MeshMatrix (face pass + vertex gather + normalise);
//! - `cc_level` / `loop_level`: build S and the refined topology from a MeshMatrix, then S·P (the cost of
//!   one level when the topology is new);
//! - `cc_spmv`: S·P alone (the per-frame cost of refining a deforming cage).
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use gregvox::mesh::{
    catmull_clark, catmull_clark_matrix, load_obj, loop_matrix, loop_subdivide, LoopBeta, Mesh,
    MeshMatrix, NormalWeighting,
};
use std::hint::black_box;
use std::time::Duration;

fn bunny() -> Mesh {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/models/stanford-bunny.obj"
    );
    load_obj(path).expect("the bunny is in assets/models")
}

fn bench(c: &mut Criterion) {
    let base = bunny();
    let loop2 = loop_subdivide(&base, 2, LoopBeta::Warren).expect("the bunny is all triangles");
    let cc2 = catmull_clark(&base, 2);
    let mut g = c.benchmark_group("mesh");
    g.sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(4));
    for (name, mesh) in [
        ("bunny", &base),
        ("bunny_loop2", &loop2),
        ("bunny_cc2", &cc2),
    ] {
        let m = MeshMatrix::from_mesh(mesh);
        g.throughput(Throughput::Elements(m.n_faces() as u64));
        g.bench_function(BenchmarkId::new("matrix", name), |b| {
            b.iter(|| black_box(MeshMatrix::from_mesh(black_box(mesh))))
        });
        g.bench_function(BenchmarkId::new("normals", name), |b| {
            b.iter(|| {
                black_box(m.vertex_normals(black_box(&mesh.positions), NormalWeighting::Area))
            })
        });
        g.bench_function(BenchmarkId::new("cc_level", name), |b| {
            b.iter(|| {
                let sub = catmull_clark_matrix(black_box(&m));
                black_box(sub.s.spmv(&mesh.positions))
            })
        });
        let sub = catmull_clark_matrix(&m);
        g.bench_function(BenchmarkId::new("cc_spmv", name), |b| {
            b.iter(|| black_box(sub.s.spmv(black_box(&mesh.positions))))
        });
        drop(sub);
        if name != "bunny_cc2" {
            g.bench_function(BenchmarkId::new("loop_level", name), |b| {
                b.iter(|| {
                    let sub = loop_matrix(black_box(&m), LoopBeta::Warren).unwrap();
                    black_box(sub.s.spmv(&mesh.positions))
                })
            });
        }
    }
    g.finish();
}

/// The GPU side of the same work: AREA vertex normals of a (deforming) mesh as two gather kernels, and one
/// Catmull–Clark level as S·P on the GPU. Each iteration is a submission waited on (the per-frame cost
/// including submission), on whichever device `GREGVOX_DEVICE` picks (lavapipe here); then the same two
/// through `engine::mesh` on the host kernels a CPU device uses (`device_normals`, `device_cc_spmv`).
fn bench_gpu(c: &mut Criterion) {
    use ash::vk;
    use gregvox::gpu::{Context, ContextDesc, MemoryLocation, Validation};
    use gregvox::passes::mesh_normals::{GpuMeshMatrix, MeshNormalsPass};
    use gregvox::passes::spmv::{GpuSparse, SpmvPass};
    let ctx = match Context::with_desc(&ContextDesc {
        validation: Validation::Off,
        ..Default::default()
    }) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("no Vulkan device, GPU benchmarks skipped: {e}");
            return;
        }
    };
    let base = bunny();
    let loop2 = loop_subdivide(&base, 2, LoopBeta::Warren).expect("the bunny is all triangles");
    let normals = MeshNormalsPass::new(&ctx).unwrap();
    let spmv = SpmvPass::new(&ctx).unwrap();
    let mut g = c.benchmark_group("mesh_gpu");
    g.sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(4));
    for (name, mesh) in [("bunny", &base), ("bunny_loop2", &loop2)] {
        let m = MeshMatrix::from_mesh(mesh);
        let pts = gregvox::mesh::host_kernels::to_vec4(&mesh.positions);
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let pb = ctx
            .upload_buffer("positions", bytemuck::cast_slice(&pts), usage)
            .unwrap();
        let nb = ctx
            .create_buffer(
                "normals",
                pts.len() as u64 * 16,
                usage,
                MemoryLocation::GpuOnly,
            )
            .unwrap();
        let gm = GpuMeshMatrix::upload(&ctx, &m).unwrap();
        g.throughput(Throughput::Elements(m.n_faces() as u64));
        g.bench_function(BenchmarkId::new("normals", name), |b| {
            b.iter(|| {
                ctx.one_shot(|cmd| normals.record(&ctx, cmd, &gm, &pb, &nb))
                    .unwrap()
            })
        });
        let sub = catmull_clark_matrix(&m);
        let s = GpuSparse::upload(&ctx, "S", &sub.s).unwrap();
        let yb = ctx
            .create_buffer(
                "refined",
                sub.s.n_rows as u64 * 16,
                usage,
                MemoryLocation::GpuOnly,
            )
            .unwrap();
        g.bench_function(BenchmarkId::new("cc_spmv", name), |b| {
            b.iter(|| {
                ctx.one_shot(|cmd| spmv.record(&ctx, cmd, &s, &pb, &yb))
                    .unwrap()
            })
        });
        use gregvox::engine::evaluator::Evaluator;
        use gregvox::engine::mesh::{point_buffer, DeviceNormals, DeviceSpmv};
        let host = Evaluator::Host;
        let hx = point_buffer(&ctx, "host positions", host, pts.len(), Some(&pts)).unwrap();
        let mut hn = point_buffer(&ctx, "host normals", host, pts.len(), None).unwrap();
        let mut hy = point_buffer(&ctx, "host refined", host, sub.s.n_rows as usize, None).unwrap();
        let mut dn = DeviceNormals::new(&ctx, &m, host).unwrap();
        let ds = DeviceSpmv::new(&ctx, &sub.s, host).unwrap();
        g.bench_function(BenchmarkId::new("device_normals", name), |b| {
            b.iter(|| dn.evaluate(&ctx, &hx, &mut hn).unwrap())
        });
        g.bench_function(BenchmarkId::new("device_cc_spmv", name), |b| {
            b.iter(|| ds.evaluate(&ctx, &hx, &mut hy).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, bench, bench_gpu);
criterion_main!(benches);
