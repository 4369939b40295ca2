//! Specification of the Vulkan foundation: compute, rendering, readback, profiler, shaders, hygiene.
//! Every case runs under the validation layer (tests/common) unless it tests the harness itself.
mod common;

use ash::vk;
use common::{validated_context, with_gpu};
use gregvox::gpu::frames::Frames;
use gregvox::gpu::pipeline::shader_module;
use gregvox::gpu::present::begin_color_target;
use gregvox::gpu::{shaders, Context, MemoryLocation, OffscreenTarget, PresentTarget, Profiler};
use gregvox::passes::iota::IotaPass;
use gregvox::passes::triangles::TrianglesPass;

fn storage_buffer(ctx: &Context, name: &str, bytes: u64) -> gregvox::gpu::Buffer {
    ctx.create_buffer(
        name,
        bytes,
        vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_SRC
            | vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuOnly,
    )
    .unwrap()
}

#[test]
fn compute_fill_is_exact_element_by_element_across_a_2d_split_dispatch() {
    // 5,000,000 invocations of 64 are 78,125 workgroups: more than the 65,535 of one dimension on lavapipe,
    // so the dispatch is split into 2 rows and the shader rebuilds the linear index.
    let n: u32 = std::env::var("IOTA_N")
        .map(|s| s.parse().unwrap())
        .unwrap_or(5_000_000);
    with_gpu(|ctx| {
        let pass = IotaPass::new(ctx).unwrap();
        let buf = storage_buffer(ctx, "iota data", n as u64 * 4 + 256);
        ctx.one_shot(|cmd| pass.record(ctx, cmd, &buf, n, 3, 7))
            .unwrap();
        let bytes = ctx.read_buffer(&buf).unwrap();
        let words: &[u32] = bytemuck::cast_slice(&bytes);
        if let Some(k) =
            (0..n as usize).find(|&i| words[i] != (i as u32).wrapping_mul(3).wrapping_add(7))
        {
            eprintln!(
                "first wrong {k}: {} ; words[0..4]={:?}",
                words[k],
                &words[0..4]
            );
        }
        let wrong = (0..n as usize)
            .filter(|&i| words[i] != (i as u32).wrapping_mul(3).wrapping_add(7))
            .count();
        assert_eq!(wrong, 0, "{wrong} of {n} elements differ from i*3+7");
    });
}

#[test]
fn upload_and_readback_round_trip_through_staging() {
    with_gpu(|ctx| {
        let data: Vec<u8> = (0..100_003u32)
            .map(|i| (i.wrapping_mul(2_654_435_761u32) >> 24) as u8)
            .collect();
        let buf = ctx
            .upload_buffer(
                "round trip",
                &data,
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            )
            .unwrap();
        assert_eq!(buf.location(), MemoryLocation::GpuOnly);
        assert_eq!(ctx.read_buffer(&buf).unwrap(), data);
        assert_eq!(
            ctx.read_buffer_range(&buf, 1000, 17).unwrap(),
            data[1000..1017]
        );
    });
}

#[test]
fn gpu_only_memory_is_never_mapped() {
    with_gpu(|ctx| {
        let mut buf = storage_buffer(ctx, "device local", 64);
        let err = buf.mapped().unwrap_err().to_string();
        assert!(err.contains("GpuOnly"), "{err}");
        assert!(buf.mapped_mut().is_err());
    });
}

/// Edge function of (a→b) at p, all coordinates in 1/16 pixel units (exact in i64).
fn edge(a: (i64, i64), b: (i64, i64), p: (i64, i64)) -> i64 {
    (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0)
}

#[test]
fn offscreen_triangle_covers_exactly_the_pixels_whose_centres_are_inside() {
    const W: u32 = 96;
    const H: u32 = 64;
    // Vertices in framebuffer pixels, on a 1/16 grid (exactly representable, finer than no rasterizer's
    // sub-pixel precision would snap them).
    let px = [(5.25f64, 3.0625f64), (88.8125, 20.4375), (20.1875, 60.6875)];
    let fixed: Vec<(i64, i64)> = px
        .iter()
        .map(|&(x, y)| ((x * 16.0) as i64, (y * 16.0) as i64))
        .collect();
    let mut expected = vec![false; (W * H) as usize];
    for j in 0..H as i64 {
        for i in 0..W as i64 {
            let c = (i * 16 + 8, j * 16 + 8);
            let e = [
                edge(fixed[0], fixed[1], c),
                edge(fixed[1], fixed[2], c),
                edge(fixed[2], fixed[0], c),
            ];
            // The vertices were chosen so no pixel centre lies on an edge: coverage is then unambiguous.
            assert!(
                e.iter().all(|&v| v != 0),
                "pixel centre ({i},{j}) lies on an edge; choose other vertices"
            );
            expected[(j * W as i64 + i) as usize] =
                e.iter().all(|&v| v > 0) || e.iter().all(|&v| v < 0);
        }
    }
    let expected_count = expected.iter().filter(|&&b| b).count();
    assert!(
        expected_count > 1500,
        "the triangle covers {expected_count} pixels"
    );

    let (covered, mismatches) = with_gpu(|ctx| {
        let mut target = OffscreenTarget::new(ctx, W, H, 1).unwrap();
        let pass = TrianglesPass::new(ctx, target.format()).unwrap();
        let clip: Vec<[f32; 4]> = px
            .iter()
            .map(|&(x, y)| {
                [
                    (x * 2.0 / W as f64 - 1.0) as f32,
                    (y * 2.0 / H as f64 - 1.0) as f32,
                    0.5,
                    1.0,
                ]
            })
            .collect();
        let vbuf = ctx
            .upload_buffer(
                "triangle",
                bytemuck::cast_slice(&clip),
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )
            .unwrap();
        let img = target.acquire(ctx, 0).unwrap().unwrap();
        ctx.one_shot(|cmd| {
            begin_color_target(ctx, cmd, img.image);
            pass.record(
                ctx,
                cmd,
                img.view,
                None,
                img.extent,
                [0.0, 0.0, 0.0, 1.0],
                &vbuf,
                3,
                Some([1.0, 1.0, 1.0]),
            );
            target.record_finish(ctx, cmd, &img);
            Ok(())
        })
        .unwrap();
        target.present(ctx, &img).unwrap();
        assert!(target.has_frame(0));
        let rgba = target.read_rgba(0).unwrap();
        // Also through PNG: write, decode, compare.
        let dir = std::env::temp_dir().join(format!("gregvox-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("triangle.png");
        target.write_png(0, &path).unwrap();
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut png_px = vec![0; reader.output_buffer_size()];
        reader.next_frame(&mut png_px).unwrap();
        assert_eq!(png_px, rgba, "the PNG holds the read-back pixels");
        let _ = std::fs::remove_dir_all(&dir);

        let mut covered = 0;
        let mut mismatches = Vec::new();
        for (k, p) in rgba.chunks_exact(4).enumerate() {
            let lit = p == [255, 255, 255, 255];
            assert!(
                lit || p == [0, 0, 0, 255],
                "pixel {k} is neither the clear colour nor the triangle: {p:?}"
            );
            covered += lit as usize;
            if lit != expected[k] {
                mismatches.push((k as u32 % W, k as u32 / W));
            }
        }
        (covered, mismatches)
    });
    assert_eq!(covered, expected_count);
    assert!(
        mismatches.is_empty(),
        "pixels differing from the centre-inside rule: {mismatches:?}"
    );
}

#[test]
fn profiler_scopes_come_back_ordered_and_positive() {
    with_gpu(|ctx| {
        let mut prof = Profiler::new(ctx, 1, 8).unwrap();
        assert!(
            prof.enabled(),
            "lavapipe and every real GPU queue here support timestamps"
        );
        let pass = IotaPass::new(ctx).unwrap();
        let a = storage_buffer(ctx, "a", 4 << 20);
        let b = storage_buffer(ctx, "b", 4 << 20);
        for _ in 0..3 {
            ctx.one_shot(|cmd| {
                let s = prof.begin(ctx, cmd, 0, "first fill");
                pass.record(ctx, cmd, &a, 1 << 20, 1, 0)?;
                prof.end(ctx, cmd, s);
                let s = prof.begin(ctx, cmd, 0, "second fill");
                pass.record(ctx, cmd, &b, 1 << 20, 2, 0)?;
                prof.end(ctx, cmd, s);
                Ok(())
            })
            .unwrap();
            prof.collect(ctx, 0).unwrap();
        }
        let stats = prof.stats();
        assert_eq!(
            stats.iter().map(|s| s.name.as_str()).collect::<Vec<_>>(),
            ["first fill", "second fill"]
        );
        for s in &stats {
            assert_eq!(s.calls, 3);
            assert!(
                s.min_ms > 0.0 && s.min_ms <= s.median_ms && s.median_ms <= s.max_ms,
                "{s:?}"
            );
            assert!(s.max_ms < 10_000.0, "{s:?}");
        }
        let trace = prof.trace();
        assert_eq!(trace.len(), 6);
        for w in trace.windows(2) {
            assert!(w[1].start_ns >= w[0].start_ns, "scopes out of order: {w:?}");
        }
        for pair in trace.chunks(2) {
            // Within one submission the second scope starts after the first one ends.
            assert!(
                pair[1].start_ns >= pair[0].start_ns + pair[0].duration_ns * 0.999,
                "{pair:?}"
            );
        }
        let json = prof.json();
        assert_eq!(json["passes"][0]["name"], "first fill");
        assert_eq!(json["passes"][1]["calls"], 3);
        assert!(json["passes"][1]["gpu_ms"]["median"].as_f64().unwrap() > 0.0);
        assert_eq!(
            prof.chrome_trace()["traceEvents"].as_array().unwrap().len(),
            6
        );
        assert!(prof.table().contains("| second fill | 3 |"));
    });
}

#[test]
fn every_embedded_shader_module_is_created_under_validation() {
    with_gpu(|ctx| {
        assert!(shaders::ALL.len() >= 3);
        for (name, words) in shaders::ALL {
            assert_eq!(words[0], 0x0723_0203, "{name} is not SPIR-V");
            let m = shader_module(ctx, name, words).unwrap();
            // SAFETY: unused module.
            unsafe { ctx.device.destroy_shader_module(m, None) };
        }
    });
}

#[test]
fn a_buffer_dropped_while_its_frame_records_lives_until_that_frame_completes() {
    with_gpu(|ctx| {
        let pass = IotaPass::new(ctx).unwrap();
        let mut frames = Frames::new(ctx, 2).unwrap();
        for frame in 0..5u32 {
            let (_, cmd) = frames.begin(ctx).unwrap();
            let name = format!("transient {frame}");
            let buf = storage_buffer(ctx, &name, 4096);
            pass.record(ctx, cmd, &buf, 1024, 1, frame).unwrap();
            // The recording references it: dropping it now must not destroy it (validation would report the
            // submission of a destroyed buffer).
            drop(buf);
            assert!(ctx.live_allocations().contains(&name));
            assert!(ctx.objects_awaiting_release() >= 1);
            frames.submit(ctx, &[], &[]).unwrap();
            // At most one transient per slot is alive: older ones were destroyed after their fence.
            assert!(
                ctx.live_allocations().len() <= 2,
                "{:?}",
                ctx.live_allocations()
            );
        }
    });
}

#[test]
fn the_harness_sees_validation_messages_and_leaks() {
    // Negative controls: the checks `with_gpu` relies on must be able to fail.
    let ctx = validated_context();
    let sink = ctx.validation.clone();
    assert!(ctx.info.validation_enabled);
    // A zero-sized buffer violates VUID-VkBufferCreateInfo-size-00912.
    let info = vk::BufferCreateInfo::default()
        .size(0)
        .usage(vk::BufferUsageFlags::STORAGE_BUFFER);
    // SAFETY: deliberately invalid; the layer reports it (lavapipe tolerates it), destroyed at once.
    unsafe {
        if let Ok(b) = ctx.device.create_buffer(&info, None) {
            ctx.device.destroy_buffer(b, None);
        }
    }
    assert!(
        sink.count() >= 1,
        "the validation sink missed an invalid vkCreateBuffer"
    );
    assert!(sink
        .messages()
        .iter()
        .any(|m| m.contains("00912") || m.contains("size")));

    let buf = ctx
        .create_buffer(
            "leak probe",
            256,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuOnly,
        )
        .unwrap();
    assert_eq!(ctx.live_allocations(), ["leak probe"]);
    drop(buf);
    assert!(ctx.live_allocations().is_empty());
}

#[test]
fn a_memory_budget_gives_a_clear_error_instead_of_a_crash() {
    let ctx = Context::with_desc(&gregvox::gpu::ContextDesc {
        validation: gregvox::gpu::Validation::Required,
        memory_budget: Some(1 << 20),
        ..Default::default()
    })
    .unwrap();
    let err = ctx
        .create_buffer(
            "too big",
            2 << 20,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuOnly,
        )
        .unwrap_err()
        .to_string();
    assert!(err.contains("too big") && err.contains("budget"), "{err}");
    assert!(ctx.live_allocations().is_empty());
    assert_eq!(ctx.validation.count(), 0);
}

#[test]
fn device_filter_that_matches_nothing_lists_the_devices() {
    let err = Context::with_desc(&gregvox::gpu::ContextDesc {
        device_filter: Some("no-such-gpu-xyz".into()),
        validation: gregvox::gpu::Validation::Off,
        ..Default::default()
    })
    .err()
    .expect("no device matches")
    .to_string();
    assert!(
        err.contains("no-such-gpu-xyz") && err.contains("devices:"),
        "{err}"
    );
}

#[test]
fn offscreen_target_applies_a_resize_at_the_next_acquire() {
    with_gpu(|ctx| {
        let mut target = OffscreenTarget::new(ctx, 32, 16, 2).unwrap();
        target.resize(vk::Extent2D {
            width: 40,
            height: 24,
        });
        let img = target.acquire(ctx, 1).unwrap().unwrap();
        assert_eq!((img.extent.width, img.extent.height), (40, 24));
        let pass = TrianglesPass::new(ctx, target.format()).unwrap();
        // A full-screen triangle: every pixel of the resized image must be painted.
        let clip: [[f32; 4]; 3] = [
            [-1.0, -1.0, 0.5, 1.0],
            [3.0, -1.0, 0.5, 1.0],
            [-1.0, 3.0, 0.5, 1.0],
        ];
        let vbuf = ctx
            .upload_buffer(
                "full screen",
                bytemuck::cast_slice(&clip),
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )
            .unwrap();
        ctx.one_shot(|cmd| {
            begin_color_target(ctx, cmd, img.image);
            pass.record(
                ctx,
                cmd,
                img.view,
                None,
                img.extent,
                [0.0; 4],
                &vbuf,
                3,
                Some([0.0, 1.0, 0.0]),
            );
            target.record_finish(ctx, cmd, &img);
            Ok(())
        })
        .unwrap();
        target.present(ctx, &img).unwrap();
        let rgba = target.read_rgba(1).unwrap();
        assert_eq!(rgba.len(), 40 * 24 * 4);
        assert!(rgba.chunks_exact(4).all(|p| p == [0, 255, 0, 255]));
        // A zero-sized target (minimised window) skips frames instead of failing.
        target.resize(vk::Extent2D {
            width: 0,
            height: 0,
        });
        assert!(target.acquire(ctx, 0).unwrap().is_none());
        assert!(target.acquire(ctx, 1).unwrap().is_none());
        // Restored: both slots exist again.
        target.resize(vk::Extent2D {
            width: 8,
            height: 8,
        });
        assert_eq!(target.acquire(ctx, 0).unwrap().unwrap().extent.width, 8);
        assert_eq!(target.acquire(ctx, 1).unwrap().unwrap().extent.height, 8);
    });
}
