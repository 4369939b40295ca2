//! gregvox inside someone else's renderer: a device the caller creates and keeps, gregvox's work recorded
//! into the caller's command buffers, and what is left when gregvox is gone.
//!
//! The host is `examples/ash_host.rs` (a plain ash program with its own instance, device, pipelines and
//! shaders), run under the validation layer with synchronization validation; its frames are compared
//! with gregvox's own surface renderer (`passes::surface_draw`, normals mode) at the same camera.
// Both hosts are standalone programs that include `examples/support/host_common.rs` themselves.
#![allow(clippy::duplicate_mod)]

mod common;

#[allow(dead_code)]
#[path = "../examples/ash_host.rs"]
mod ash_host;

#[allow(dead_code)]
#[path = "../examples/wgpu_host.rs"]
mod wgpu_host;

use ash::vk;
use common::{differing, render_frame, validated_gpu, FRAME_FORMAT};
use gregvox::api::{Deformation, SurfaceBuffers, SurfaceUpdate, VertexTarget};
use gregvox::gpu::MemoryLocation;
use gregvox::passes::surface_draw::{SurfaceDrawPass, SurfacePush};

/// The host's clear colour as the 8-bit pixel it becomes.
fn clear_pixel() -> [u8; 4] {
    ash_host::CLEAR.map(|c| (c * 255.0).round() as u8)
}

/// Pixels that are not the clear colour.
fn drawn(px: &[u8]) -> usize {
    let bg = clear_pixel();
    px.chunks_exact(4)
        .filter(|p| p.iter().zip(bg).any(|(a, b)| a.abs_diff(b) > 1))
        .count()
}

fn pixel(px: &[u8], w: u32, x: u32, y: u32) -> [u8; 4] {
    let i = ((y * w + x) * 4) as usize;
    [px[i], px[i + 1], px[i + 2], px[i + 3]]
}

/// A frame of gregvox's own renderer to compare a host's with.
struct OwnFrame {
    level: u32,
    deformation: Deformation,
    t: f32,
    amplitude: f32,
    view_proj: glam::Mat4,
    eye: glam::Vec3,
    width: u32,
    height: u32,
}

/// gregvox's own device and renderer: the built-in cage with the deformation, drawn by the surface pass
/// (normals mode) on the hosts' clear colour; RGBA8 pixels.
fn own_render(f: &OwnFrame) -> Vec<u8> {
    let gpu = validated_gpu();
    let own = {
        let ctx = gpu.context();
        let cage = gregvox::engine::cage::builtin_cage(4, 2, 2);
        let mut surface = gpu.gregory_surface(&cage, f.level).unwrap();
        surface.deform(f.deformation, f.t, f.amplitude).unwrap();
        let pass = SurfaceDrawPass::new(ctx, FRAME_FORMAT, vk::Format::D32_SFLOAT).unwrap();
        let push = SurfacePush {
            view_proj: f.view_proj.to_cols_array_2d(),
            eye: [f.eye.x, f.eye.y, f.eye.z, 1.0],
            light: [0.0, 0.0, 1.0, 0.2],
            color: [1.0; 4],
            mode: [1, f.level, 0, 0],
        };
        render_frame(ctx, f.width, f.height, |cmd, target| {
            let e = surface.engine();
            pass.record(
                ctx,
                cmd,
                target,
                Some(ash_host::CLEAR),
                e.vertices(),
                e.indices(),
                e.index_count(),
                &push,
            );
            Ok(())
        })
    };
    gpu.finish().unwrap();
    own
}

#[test]
fn a_caller_device_drives_100_deforming_frames_and_is_left_with_nothing_of_gregvox() {
    let opts = ash_host::HostOptions {
        frames: 100,
        keep: vec![0, 50, 99],
        validation: true,
        level_change_at: Some(60),
        second_surface_until: Some(30),
        ..Default::default()
    };
    let run = ash_host::run(&opts).expect("the ash host runs");
    assert!(
        run.validation_messages.is_empty(),
        "{} validation message(s):\n{}",
        run.validation_messages.len(),
        run.validation_messages.join("\n")
    );
    assert!(
        run.gregvox_allocations_left.is_empty(),
        "gregvox allocations left after its surface was dropped: {:?}",
        run.gregvox_allocations_left
    );
    assert_eq!(run.frames.len(), 3);
    let (w, h) = (opts.width, opts.height);
    for (f, px) in &run.frames {
        // The surface covers a good part of the frame; the host's own triangle is in its corner.
        let n = drawn(px);
        assert!(n > (w * h / 20) as usize, "frame {f}: {n} pixels drawn");
        let corner = pixel(px, w, 12, h - 12);
        assert!(
            corner[0] > 150 && corner[2] < 120,
            "frame {f}: corner {corner:?}"
        );
    }
    // The surface deforms from frame to frame.
    let d = differing(&run.frames[0].1, &run.frames[2].1, 8);
    assert!(d > 0.01, "frames 0 and 99 differ in {d} of the pixels");
    // After gregvox was destroyed the host still draws with its own objects: its triangle, no surface.
    let after = &run.after_gregvox;
    assert!(pixel(after, w, 12, h - 12)[0] > 150);
    assert_eq!(pixel(after, w, w / 2, h / 2), clear_pixel());
    let own = drawn(after);
    assert!(own > 100 && own < (w * h / 10) as usize, "{own} pixels");
}

#[test]
fn the_host_frame_equals_gregvox_own_renderer_at_the_same_camera() {
    let frame = 37;
    let opts = ash_host::HostOptions {
        frames: frame + 1,
        keep: vec![frame],
        scene: false,
        validation: true,
        ..Default::default()
    };
    let run = ash_host::run(&opts).expect("the ash host runs");
    assert!(
        run.validation_messages.is_empty(),
        "{:?}",
        run.validation_messages
    );
    let host_px = &run.frames[0].1;
    let (w, h) = (opts.width, opts.height);

    let own = own_render(&OwnFrame {
        level: opts.level,
        deformation: opts.deformation,
        t: frame as f32 * opts.time_step,
        amplitude: opts.amplitude,
        view_proj: run.view_proj,
        eye: run.eye,
        width: w,
        height: h,
    });
    assert!(drawn(&own) > (w * h / 20) as usize);
    let d = differing(host_px, &own, 2);
    assert!(
        d <= 0.002,
        "{:.3} % of the pixels differ between the host's frame and gregvox's own render",
        d * 100.0
    );
}

#[test]
fn adaptive_levels_and_indirect_draws_recorded_in_the_host_frame_draw_the_uniform_surface() {
    let frame = 12;
    let base = ash_host::HostOptions {
        frames: frame + 1,
        keep: vec![frame],
        scene: false,
        validation: true,
        level: 8,
        ..Default::default()
    };
    let uniform = ash_host::run(&base).expect("the ash host runs");
    let adaptive = ash_host::run(&ash_host::HostOptions {
        adaptive: Some(4.0),
        ..base.clone()
    })
    .expect("the ash host runs adaptively");
    for run in [&uniform, &adaptive] {
        assert!(
            run.validation_messages.is_empty(),
            "{:?}",
            run.validation_messages
        );
        assert!(run.gregvox_allocations_left.is_empty());
    }
    // The levels follow the view: the near patches finer than the far ones, none past the maximum.
    let levels = &adaptive.adaptive_levels;
    let (lo, hi) = (levels.iter().min().unwrap(), levels.iter().max().unwrap());
    assert!(
        *lo >= 1 && *hi <= base.level && lo < hi,
        "levels {levels:?}"
    );
    let (a, u) = (&adaptive.frames[0].1, &uniform.frames[0].1);
    let (w, h) = (base.width, base.height);
    assert!(drawn(a) > (w * h / 20) as usize);
    // Coarser patches far from the camera move the silhouette and the normals a little, no more.
    let coverage = drawn(a) as f64 / drawn(u) as f64;
    assert!((coverage - 1.0).abs() < 0.02, "coverage ratio {coverage}");
    let d = differing(a, u, 24);
    assert!(d < 0.03, "{:.2} % of the pixels differ", d * 100.0);
}

#[test]
fn a_wgpu_host_draws_gregvox_vertices_from_its_own_buffer_as_gregvox_renders_them() {
    let frame = 23;
    let opts = wgpu_host::HostOptions {
        frames: frame + 1,
        keep: vec![0, frame],
        validation: true,
        ..Default::default()
    };
    // wgpu falls back silently without the layer; gregvox's messenger on wgpu's instance turns every
    // validation message into an error of `Gpu::finish`, which `run` returns.
    let run = wgpu_host::run(&opts).expect("the wgpu host runs with no validation message");
    assert!(run.validated, "the validation layer was not on");
    let (w, h) = (opts.width, opts.height);
    let first = &run.frames[0].1;
    let host_px = &run.frames[1].1;
    assert!(drawn(host_px) > (w * h / 20) as usize);
    assert!(
        differing(first, host_px, 8) > 0.01,
        "the surface did not move"
    );
    let own = own_render(&OwnFrame {
        level: opts.level,
        deformation: opts.deformation,
        t: frame as f32 * opts.time_step,
        amplitude: opts.amplitude,
        view_proj: run.view_proj,
        eye: run.eye,
        width: w,
        height: h,
    });
    let d = differing(host_px, &own, 2);
    assert!(
        d <= 0.002,
        "{:.3} % of the pixels differ between wgpu's frame and gregvox's own render",
        d * 100.0
    );
}

#[test]
fn the_requirements_list_what_the_owned_path_enables_and_refuse_vulkan_1_1() {
    let gpu = validated_gpu();
    let ctx = gpu.context();
    let req =
        gregvox::api::Gpu::requirements(&ctx.instance, ctx.physical_device, vk::API_VERSION_1_3)
            .unwrap();
    assert!(req
        .device_extensions
        .contains(&ash::khr::push_descriptor::NAME));
    assert_eq!(req.queue_family, ctx.queue_family);
    if !req.core13 {
        assert!(req
            .device_extensions
            .contains(&ash::khr::synchronization2::NAME));
    }
    // The optional features name what gregvox does without each.
    let optional = req.optional();
    assert_eq!(optional.len(), 9);
    assert!(optional
        .iter()
        .any(|(name, _, without)| *name == "shaderFloat64" && without.contains("CPU")));
    let err =
        gregvox::api::Gpu::requirements(&ctx.instance, ctx.physical_device, vk::API_VERSION_1_1)
            .unwrap_err()
            .to_string();
    assert!(err.contains("Vulkan 1.2"), "{err}");
    assert!(ctx.owns_device());
    drop(req);
    gpu.finish().unwrap();
}

#[test]
fn a_surface_evaluates_into_a_range_of_the_callers_buffer_as_into_its_own() {
    let gpu = validated_gpu();
    {
        let ctx = gpu.context();
        let cage = gregvox::engine::cage::builtin_cage(2, 2, 1);
        let mut surface = gpu.gregory_surface(&cage, 3).unwrap();
        let bytes = surface.vertex_bytes();
        let align = ctx.limits.min_storage_buffer_offset_alignment.max(16);
        let offset = 3 * align;
        let theirs = ctx
            .create_buffer(
                "the caller's vertex buffer",
                offset + bytes + 256,
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::VERTEX_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::GpuOnly,
            )
            .unwrap();
        let update = SurfaceUpdate {
            deformation: Deformation::Bend,
            t: 0.7,
            amplitude: 0.3,
            target: Some(VertexTarget {
                buffer: theirs.raw(),
                offset,
                size: bytes,
            }),
        };
        let recording = gpu.begin_recording().unwrap();
        ctx.one_shot(|cmd| surface.record(cmd, &update)).unwrap();
        drop(recording);
        let got = ctx.read_buffer_range(&theirs, offset, bytes).unwrap();
        // The same update into the surface's own buffer.
        surface.deform(Deformation::Bend, 0.7, 0.3).unwrap();
        let own: Vec<u8> = bytemuck::cast_slice(&surface.read_vertices().unwrap()).to_vec();
        assert_eq!(got.len(), own.len());
        let a: &[f32] = bytemuck::cast_slice(&got);
        let b: &[f32] = bytemuck::cast_slice(&own);
        let worst = a
            .iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-5, "worst difference {worst}");
        assert_eq!(
            surface.buffers().vertex_bytes,
            bytes,
            "the buffers report the bytes a target needs"
        );
        assert_eq!(SurfaceBuffers::VERTEX_STRIDE, 32);

        // A target that starts off the storage alignment, or is too short, is refused by name.
        for (offset, size, what) in [
            (align + 4, bytes, "minStorageBufferOffsetAlignment"),
            (0, bytes - 32, "do not fit"),
        ] {
            let bad = SurfaceUpdate {
                target: Some(VertexTarget {
                    buffer: theirs.raw(),
                    offset,
                    size,
                }),
                ..SurfaceUpdate::default()
            };
            let err = ctx
                .one_shot(|cmd| surface.record(cmd, &bad))
                .unwrap_err()
                .to_string();
            assert!(err.contains(what), "{err}");
        }
        surface.set_level(4).unwrap();
    }
    gpu.finish().unwrap();
}

#[test]
fn the_recorded_curvature_stream_equals_the_surface_curvature() {
    let gpu = validated_gpu();
    {
        let ctx = gpu.context();
        let cage = gregvox::engine::cage::builtin_cage(3, 2, 2);
        let mut surface = gpu.gregory_surface(&cage, 5).unwrap();
        surface.enable_curvature().unwrap();
        surface.set_level(4).unwrap();
        let update = SurfaceUpdate {
            deformation: Deformation::Twist,
            t: 0.4,
            amplitude: 0.3,
            target: None,
        };
        let bytes = surface.vertex_bytes() / 4; // (H, K): 8 bytes a vertex against 32
        let out = ctx
            .create_buffer(
                "curvature read back",
                bytes,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )
            .unwrap();
        let curvature = surface.buffers().curvature.expect("curvature enabled");
        ctx.one_shot(|cmd| {
            surface.record(cmd, &update)?;
            // SAFETY: recording; record's end barrier made the stream visible to transfers.
            unsafe {
                ctx.device.cmd_copy_buffer(
                    cmd,
                    curvature,
                    out.raw(),
                    &[vk::BufferCopy {
                        src_offset: 0,
                        dst_offset: 0,
                        size: bytes,
                    }],
                )
            };
            gregvox::gpu::resources::memory_barrier(
                ctx,
                cmd,
                (
                    vk::PipelineStageFlags2::COPY,
                    vk::AccessFlags2::TRANSFER_WRITE,
                ),
                (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ),
            );
            Ok(())
        })
        .unwrap();
        let got: Vec<[f32; 2]> = bytemuck::cast_slice(out.mapped().unwrap()).to_vec();
        // The reference: the engine's curvature of the same control points (the ones just recorded).
        let want = surface.engine().curvature(ctx).unwrap();
        assert_eq!(got.len(), want.len());
        let scale = want
            .iter()
            .flat_map(|c| [c[0].abs(), c[1].abs().sqrt()])
            .fold(0.0f32, f32::max);
        assert!(scale > 0.1, "a twisted box is curved: {scale}");
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert!(
                (g[0] - w[0]).abs() <= 1e-3 * scale && (g[1] - w[1]).abs() <= 1e-3 * scale * scale,
                "vertex {i}: recorded {g:?}, engine {w:?}"
            );
        }
    }
    gpu.finish().unwrap();
}
