//! GPU objects release themselves: surfaces, voxelizers and passes dropped mid-way through an error, or while
//! a frame that uses them is being recorded, end with no live allocation and no validation message.
mod common;
use ash::vk;
use common::{model, with_gpu};
use gregvox::engine::voxelize::PeelVoxelizer;
use gregvox::gpu::{Context, ContextDesc, Frames, MemoryLocation, Validation};
use gregvox::passes::iota::IotaPass;
use gregvox::{load_mesh, Axes, Gpu, VoxelizeOptions};

/// A validated context whose allocations stop at `budget` bytes.
fn budget_context(budget: u64) -> Context {
    Context::with_desc(&ContextDesc {
        validation: Validation::Required,
        sync_validation: true,
        memory_budget: Some(budget),
        ..Default::default()
    })
    .expect("a Vulkan device with the validation layer")
}

/// Waits for the device, then requires nothing alive and nothing reported.
fn assert_clean(ctx: &Context) {
    ctx.wait_idle().unwrap();
    assert_eq!(ctx.live_allocations(), Vec::<String>::new());
    assert_eq!(ctx.objects_awaiting_release(), 0);
    assert_eq!(
        ctx.validation.count(),
        0,
        "{}",
        ctx.validation.messages().join("\n")
    );
}

#[test]
fn a_gregory_surface_that_runs_out_of_memory_half_built_releases_what_it_made() {
    let cage = load_mesh(model("spot_quadrangulated.obj")).unwrap();
    let (topo, rest, _) =
        gregvox::engine::cage::cage_topology(&cage, gregvox::surface::Tangents::OpenSubdiv)
            .unwrap();
    // Level 64 needs 377 MiB of vertices; W, the points and the passes fit in 8 MiB first.
    let ctx = budget_context(8 << 20);
    let err = gregvox::engine::gregory::GregorySurface::new(&ctx, &topo, &rest, 64)
        .err()
        .expect("over the budget");
    assert!(err.to_string().contains("budget"), "{err}");
    assert_clean(&ctx);
    // The same context still builds a surface that fits, and drops it cleanly.
    let s = gregvox::engine::gregory::GregorySurface::new(&ctx, &topo, &rest, 2).unwrap();
    assert!(ctx.allocated_bytes() > 0);
    drop(s);
    assert_clean(&ctx);
    assert_eq!(ctx.allocated_bytes(), 0);
}

#[test]
fn a_voxelizer_that_fails_mid_voxelization_releases_its_images_and_slabs() {
    let bunny = load_mesh(model("stanford-bunny.obj")).unwrap();
    // Past the layer cap: the count pre-pass ran, layer images may exist, then the peel is refused.
    let gpu = Gpu::with_desc(&ContextDesc {
        validation: Validation::Required,
        sync_validation: true,
        ..Default::default()
    })
    .unwrap();
    let opts = VoxelizeOptions::default()
        .res(64)
        .method(gregvox::Method::Peel)
        .axes(Axes::Three)
        .max_layers(1);
    let err = gpu.voxelize(&bunny, &opts).unwrap_err().to_string();
    assert!(err.contains("layer"), "{err}");
    assert_clean(gpu.context());
    // Over the memory budget part-way through the per-axis resources.
    let ctx = budget_context(3 << 20);
    let tri = gregvox::voxel::mesh::TriMesh::fan(&bunny).clean().0;
    let frame = gregvox::voxel::grid::GridFrame::from_points(&tri.positions, 512).unwrap();
    let v = PeelVoxelizer::new(&ctx, 12).unwrap();
    let gpu_tri = gregvox::engine::voxelize::GpuTriangles::upload(&ctx, &tri).unwrap();
    let err = v
        .voxelize(
            &ctx,
            &gpu_tri.geometry(),
            &frame,
            &[gregvox::voxel::grid::Axis::Z],
            gregvox::voxel::cpu::FillRule::Winding,
            None,
        )
        .expect_err("over the budget");
    assert!(err.to_string().contains("budget"), "{err}");
    drop((v, gpu_tri));
    assert_clean(&ctx);
}

#[test]
fn a_pass_and_its_buffer_dropped_while_their_frame_records_stay_alive_until_it_completes() {
    with_gpu(|ctx| {
        let mut frames = Frames::new(ctx, 2).unwrap();
        for frame in 0..3u32 {
            let pass = IotaPass::new(ctx).unwrap();
            let buf = ctx
                .create_buffer(
                    &format!("frame buffer {frame}"),
                    4096,
                    vk::BufferUsageFlags::STORAGE_BUFFER,
                    MemoryLocation::GpuOnly,
                )
                .unwrap();
            let (_, cmd) = frames.begin(ctx).unwrap();
            pass.record(ctx, cmd, &buf, 1024, 1, frame).unwrap();
            // Both are referenced by the recording: dropped now, destroyed after the frame's fence.
            drop(pass);
            drop(buf);
            frames.submit(ctx, &[], &[]).unwrap();
        }
        // An error between begin and submit abandons the recording; what it pinned is still released.
        let (_, _cmd) = frames.begin(ctx).unwrap();
        let orphan = ctx
            .create_buffer(
                "abandoned",
                256,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::GpuOnly,
            )
            .unwrap();
        drop(orphan);
        drop(frames);
        ctx.wait_idle().unwrap();
        assert_eq!(ctx.objects_awaiting_release(), 0);
    });
}

#[test]
fn one_gpu_keeps_its_voxelizers_between_calls_and_each_call_sets_its_own_options() {
    // The batch path: many models through one `Gpu`, whose peel and A-buffer pipelines are made once.
    // A cached voxelizer must not carry a setting (here the layer cap of a refused call) into the next
    // call, must give the bits a fresh device gives, and must be released by `finish`.
    let models = [
        "stanford-bunny.obj",
        "spot_quadrangulated.obj",
        "stanford-bunny.obj",
    ];
    let desc = ContextDesc {
        validation: Validation::Required,
        ..Default::default()
    };
    let kept = Gpu::with_desc(&desc).unwrap();
    for method in [gregvox::Method::Peel, gregvox::Method::Abuffer] {
        for (i, name) in models.iter().enumerate() {
            let mesh = load_mesh(model(name)).unwrap();
            let opts = VoxelizeOptions::default()
                .res(48 + 8 * i as u32)
                .method(method);
            if method == gregvox::Method::Peel {
                let refused = kept.voxelize(&mesh, &opts.clone().max_layers(1));
                assert!(refused.is_err(), "{name}: one layer is too few");
            }
            let again = kept.voxelize(&mesh, &opts).unwrap();
            let fresh_gpu = Gpu::with_desc(&desc).unwrap();
            let fresh = fresh_gpu.voxelize(&mesh, &opts).unwrap();
            fresh_gpu.finish().unwrap();
            assert!(again.grid.count() > 0, "{name}");
            assert!(
                again.grid == fresh.grid,
                "{name} {method:?}: a kept voxelizer gives other bits than a fresh one"
            );
        }
    }
    kept.finish().unwrap();
}
