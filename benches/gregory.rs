//! Gregory kernels on spot_quadrangulated (2,928 patches). Run: `cargo bench --bench gregory`.
//! `gregvox bench --suite gregory` reports the same work as vertices/s from timestamps beside OpenSubdiv.
//!
//! - `points`: W·cage, the ACC-2 control points of every patch (CPU SpMV, f64);
//! - `cpu_eval/L`: the f64 reference evaluation with normals of every patch on its (L+1)² grid;
//! - `gpu_eval/CAGE/L`: the GPU evaluation pass alone (control points computed once), one submission waited
//!   on per iteration, on whichever device `GREGVOX_DEVICE` picks (lavapipe here), at the levels 4–64 of
//!   `gregvox bench --suite gregory` on spot and on the many-EV cage icosphere3_cc1;
//! - `host_eval/CAGE/L`: the host evaluator (surface::gregory_host, every core; what CPU devices use) on the
//!   same cages and levels, from the same control points.
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use gregvox::engine::gregory::{Evaluator, GregorySurface};
use gregvox::mesh::load_obj;
use gregvox::passes::gregory_eval::vertex_count;
use gregvox::surface::{tessellate, GregoryStencils, Tangents};
use std::hint::black_box;
use std::time::Duration;

fn spot() -> gregvox::mesh::Mesh {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/models/spot_quadrangulated.obj"
    );
    load_obj(path).expect("spot_quadrangulated is in assets/models")
}

fn bench_cpu(c: &mut Criterion) {
    let mesh = spot();
    let s = GregoryStencils::from_mesh(&mesh, Tangents::OpenSubdiv)
        .expect("spot is an all-quad manifold cage")
        .stencils;
    let patches = s.patches_f64(&mesh.positions).unwrap();
    let mut g = c.benchmark_group("gregory");
    g.sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(4));
    g.throughput(Throughput::Elements(s.w.n_rows as u64));
    g.bench_function("points", |b| {
        b.iter(|| black_box(s.points(black_box(&mesh.positions)).unwrap()))
    });
    for level in [4u32, 16] {
        g.throughput(Throughput::Elements(vertex_count(
            patches.len() as u32,
            level,
        )));
        g.bench_function(BenchmarkId::new("cpu_eval", level), |b| {
            b.iter(|| black_box(tessellate(black_box(&patches), level)))
        });
    }
    g.finish();
}

fn bench_gpu(c: &mut Criterion) {
    use ash::vk;
    use gregvox::gpu::{Context, ContextDesc, MemoryLocation, Validation};
    use gregvox::passes::gregory_eval::GregoryEvalPass;
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
    let mut g = c.benchmark_group("gregory_gpu");
    g.sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    let eval = GregoryEvalPass::new(&ctx).unwrap();
    // The cages and levels of `gregvox bench --suite gregory`: spot, and the cage where half the vertices
    // are extraordinary.
    let many_ev = gregvox::engine::cage::icosphere_quad_cage(3);
    for (name, mesh) in [("spot", spot()), ("icosphere3_cc1", many_ev)] {
        let (topo, cage, _) =
            gregvox::engine::cage::cage_topology(&mesh, Tangents::OpenSubdiv).unwrap();
        let n = topo.patch_points.len() as u32;
        let ids: Vec<u32> = topo.patch_points.iter().flatten().copied().collect();
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let pp = ctx
            .upload_buffer("patch points", bytemuck::cast_slice(&ids), storage)
            .unwrap();
        let pf = ctx
            .upload_buffer(
                "patch flags",
                bytemuck::cast_slice(&topo.patch_flags),
                storage,
            )
            .unwrap();
        for level in [4u32, 8, 16, 32, 64] {
            let surface = GregorySurface::new(&ctx, &topo, &cage, level).unwrap();
            ctx.one_shot(|cmd| surface.record(&ctx, cmd, None, None))
                .unwrap();
            let out = ctx
                .create_buffer(
                    "vertices",
                    vertex_count(n, level) * 32,
                    storage,
                    MemoryLocation::GpuOnly,
                )
                .unwrap();
            g.throughput(Throughput::Elements(vertex_count(n, level)));
            let mut host =
                GregorySurface::with_evaluator(&ctx, &topo, &cage, level, Evaluator::Host).unwrap();
            host.evaluate(&ctx, None, None).unwrap();
            g.bench_function(BenchmarkId::new(format!("host_eval/{name}"), level), |b| {
                b.iter(|| host.evaluate_host().unwrap())
            });
            g.bench_function(
                BenchmarkId::new(format!("host_curvature/{name}"), level),
                |b| b.iter(|| host.curvature(&ctx).unwrap()),
            );
            g.bench_function(BenchmarkId::new(format!("gpu_eval/{name}"), level), |b| {
                b.iter(|| {
                    ctx.one_shot(|cmd| {
                        eval.record(
                            &ctx,
                            cmd,
                            surface.control_points(),
                            &pp,
                            &pf,
                            n,
                            level,
                            true,
                            &out,
                        )
                    })
                    .unwrap()
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench_cpu, bench_gpu);
criterion_main!(benches);
