//! Specification of the Beziex path: every sample model loads and evaluates without NaN on the CPU and the GPU,
//! shared edges (matched by their boundary curves) are G1, and the vertex-pull path equals the compute path for
//! Beziex and Gregory patches.
mod common;

use ash::vk;
use common::{model, with_gpu};
use glam::DVec3;
use gregvox::geom::gregory::PatchF64;
use gregvox::gpu::present::begin_color_target;
use gregvox::gpu::resources::image_barrier;
use gregvox::gpu::{Buffer, Context, ImageDesc, MemoryLocation};
use gregvox::passes::beziex_eval::BeziexEvalPass;
use gregvox::passes::gregory_eval::{grid_indices, vertex_count, GregoryEvalPass, SurfaceVertex};
use gregvox::passes::patch_pull::{PatchKind, PatchPullPass};
use gregvox::passes::surface_draw::{DrawTarget, SurfacePush};
use gregvox::surface::beziex::{load_beziex, BeziexPatch};

const FILES: [&str; 6] = [
    "04_Cup1.gzjson",
    "18_Ring0.gzjson",
    "19_Sphere1.gzjson",
    "Manatee_01.gzjson",
    "MascuteAzur001.gzjson",
    "MascutePav001.gzjson",
];

fn load(name: &str) -> Vec<BeziexPatch> {
    load_beziex(model(&format!("beziex/{name}"))).unwrap()
}

fn diag(patches: &[BeziexPatch]) -> f64 {
    let (mut lo, mut hi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
    for p in patches.iter().flat_map(|p| p.ra.iter().flatten()) {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    (hi - lo).length()
}

fn storage(ctx: &Context, name: &str, bytes: &[u8]) -> Buffer {
    ctx.upload_buffer(
        name,
        bytes,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
    )
    .unwrap()
}

fn output(ctx: &Context, name: &str, bytes: u64) -> Buffer {
    ctx.create_buffer(
        name,
        bytes,
        vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::VERTEX_BUFFER
            | vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
    )
    .unwrap()
}

fn gpu_compute(patches: &[BeziexPatch], level: u32) -> Vec<SurfaceVertex> {
    let nets: Vec<[f32; 4]> = patches.iter().flat_map(|p| p.to_gpu()).collect();
    with_gpu(|ctx| {
        let pass = BeziexEvalPass::new(ctx).unwrap();
        let nb = storage(ctx, "nets", bytemuck::cast_slice(&nets));
        let out = output(
            ctx,
            "vertices",
            vertex_count(patches.len() as u32, level) * 32,
        );
        ctx.one_shot(|cmd| pass.record(ctx, cmd, &nb, patches.len() as u32, level, &out))
            .unwrap();
        ctx.read_pod::<SurfaceVertex>(&out).unwrap()
    })
}

#[test]
fn every_sample_model_loads_and_evaluates_without_nan_and_the_gpu_matches_the_cpu() {
    for name in FILES {
        let patches = load(name);
        let level = 8;
        let gpu = gpu_compute(&patches, level);
        let d = diag(&patches);
        let n = (level + 1) as usize;
        let mut worst = 0.0f64;
        for (k, p) in patches.iter().enumerate() {
            for j in 0..n {
                for i in 0..n {
                    let (u, v) = (i as f64 / level as f64, j as f64 / level as f64);
                    let (s, su, sv) = p.eval(u, v);
                    assert!(
                        s.is_finite() && su.is_finite() && sv.is_finite(),
                        "{name} patch {k} at ({u}, {v})"
                    );
                    let g = gpu[k * n * n + j * n + i];
                    assert!(
                        g.position.iter().chain(&g.normal).all(|c| c.is_finite()),
                        "{name}: GPU NaN"
                    );
                    let gp = DVec3::new(
                        g.position[0] as f64,
                        g.position[1] as f64,
                        g.position[2] as f64,
                    );
                    worst = worst.max((gp - s).length() / d);
                }
            }
        }
        eprintln!(
            "{name}: {} patches, GPU vs f64 {worst:.2e} × diag",
            patches.len()
        );
        assert!(worst < 1e-5, "{name}: {worst}");
    }
}

/// Max normal jump over edges shared by two patches, matched by their elevated boundary curves.
fn max_shared_edge_jump(patches: &[BeziexPatch]) -> (usize, f64) {
    let d = diag(patches);
    let curve = |p: &BeziexPatch, e: usize| -> [DVec3; 7] {
        match e {
            0 => p.ra[0],
            1 => p.rb[3],
            2 => p.ra[3],
            _ => p.rb[0],
        }
    };
    let uv = |e: usize, t: f64| match e {
        0 => (t, 0.0),
        1 => (1.0, t),
        2 => (t, 1.0),
        _ => (0.0, t),
    };
    let same = |a: &[DVec3; 7], b: &[DVec3; 7], rev: bool| {
        (0..7).all(|k| (a[k] - b[if rev { 6 - k } else { k }]).length() < 1e-6 * d)
    };
    let (mut pairs, mut worst) = (0, 0.0f64);
    for a in 0..patches.len() {
        for ea in 0..4 {
            let ca = curve(&patches[a], ea);
            for pb in patches.iter().skip(a + 1) {
                for eb in 0..4 {
                    let cb = curve(pb, eb);
                    for rev in [false, true] {
                        if !same(&ca, &cb, rev) {
                            continue;
                        }
                        pairs += 1;
                        let mut edge_worst = 0.0f64;
                        for k in 0..=32 {
                            let t = k as f64 / 32.0;
                            let (ua, va) = uv(ea, t);
                            let (ub, vb) = uv(eb, if rev { 1.0 - t } else { t });
                            let (na, nb) = (patches[a].normal(ua, va), pb.normal(ub, vb));
                            // Up to orientation: 04_Cup1's mirrored pre-divided halves have flipped (u, v) frames
                            // (their normals point the other way; the original viewer shades two-sided).
                            let theta = na.cross(nb).length().atan2(na.dot(nb));
                            edge_worst = edge_worst.max(theta.min(std::f64::consts::PI - theta));
                        }
                        worst = worst.max(edge_worst);
                    }
                }
            }
        }
    }
    (pairs, worst)
}

#[test]
fn shared_edges_of_the_sphere_and_the_cup_are_g1() {
    for (name, min_pairs) in [("19_Sphere1.gzjson", 48), ("04_Cup1.gzjson", 40)] {
        let patches = load(name);
        let (pairs, worst) = max_shared_edge_jump(&patches);
        eprintln!("{name}: {pairs} shared edges matched, max normal jump {worst:.2e} rad");
        assert!(
            pairs >= min_pairs,
            "{name}: only {pairs} shared edges found"
        );
        assert!(worst <= 1e-3, "{name}: {worst}");
    }
}

/// Draws `patch_count` patches through the capture variant of the vertex-pull path and returns the vertices.
fn vertex_pull(
    kind: PatchKind,
    points: &[[f32; 4]],
    patch_points: &[u32],
    patch_count: u32,
    level: u32,
) -> Vec<SurfaceVertex> {
    with_gpu(|ctx| {
        let (w, h) = (64, 64);
        let color = ctx
            .create_image(
                "pull color",
                &ImageDesc::d2(
                    w,
                    h,
                    vk::Format::B8G8R8A8_UNORM,
                    vk::ImageUsageFlags::COLOR_ATTACHMENT,
                ),
            )
            .unwrap();
        let depth = ctx
            .create_image(
                "pull depth",
                &ImageDesc::d2(
                    w,
                    h,
                    vk::Format::D32_SFLOAT,
                    vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
                ),
            )
            .unwrap();
        let pass = PatchPullPass::new(
            ctx,
            vk::Format::B8G8R8A8_UNORM,
            vk::Format::D32_SFLOAT,
            true,
        )
        .unwrap();
        let pb = storage(ctx, "points", bytemuck::cast_slice(points));
        let ib = storage(ctx, "patch points", bytemuck::cast_slice(patch_points));
        let grid = ctx
            .upload_buffer(
                "grid",
                bytemuck::cast_slice(&grid_indices(1, level)),
                vk::BufferUsageFlags::INDEX_BUFFER,
            )
            .unwrap();
        let cap = output(ctx, "captured", vertex_count(patch_count, level) * 32);
        let push = SurfacePush {
            view_proj: glam::Mat4::IDENTITY.to_cols_array_2d(),
            eye: [0.0, 0.0, 5.0, 1.0],
            light: [0.0, 0.0, 1.0, 0.3],
            color: [1.0; 4],
            mode: [0; 4],
        };
        ctx.one_shot(|cmd| {
            begin_color_target(ctx, cmd, color.raw());
            image_barrier(
                ctx,
                cmd,
                depth.raw(),
                depth.range(),
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
                (vk::PipelineStageFlags2::NONE, vk::AccessFlags2::NONE),
                (
                    vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS,
                    vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE,
                ),
            );
            let target = DrawTarget {
                color: color.view(),
                depth: depth.view(),
                extent: vk::Extent2D {
                    width: w,
                    height: h,
                },
            };
            pass.record(
                ctx,
                cmd,
                &target,
                Some([0.0; 4]),
                kind,
                gregvox::passes::gregory_eval::ControlPoints::plain(&pb),
                &ib,
                patch_count,
                level,
                &grid,
                Some(&cap),
                &push,
            )
        })
        .unwrap();
        ctx.read_pod::<SurfaceVertex>(&cap).unwrap()
    })
}

fn max_diff(a: &[SurfaceVertex], b: &[SurfaceVertex]) -> (f32, f32) {
    assert_eq!(a.len(), b.len());
    let mut p = 0.0f32;
    let mut n = 0.0f32;
    for (x, y) in a.iter().zip(b) {
        for k in 0..3 {
            p = p.max((x.position[k] - y.position[k]).abs());
            n = n.max((x.normal[k] - y.normal[k]).abs());
        }
    }
    (p, n)
}

#[test]
fn vertex_pull_equals_compute_for_beziex_and_gregory_patches() {
    let level = 12;
    let sphere = load("19_Sphere1.gzjson");
    let nets: Vec<[f32; 4]> = sphere.iter().flat_map(|p| p.to_gpu()).collect();
    let pulled = vertex_pull(PatchKind::Beziex, &nets, &[0], sphere.len() as u32, level);
    let computed = gpu_compute(&sphere, level);
    let (dp, dn) = max_diff(&pulled, &computed);
    let d = diag(&sphere) as f32;
    eprintln!("beziex sphere: vertex-pull vs compute |Δp| {dp:.2e} (diag {d:.2}), |Δn| {dn:.2e}");
    assert!(dp <= 1e-6 * d && dn <= 1e-5, "{dp} {dn}");

    // Gregory: a row of bent patches.
    let patches: Vec<PatchF64> = (0..8)
        .map(|s| {
            let b: [[DVec3; 4]; 4] = std::array::from_fn(|j| {
                std::array::from_fn(|i| {
                    DVec3::new(
                        i as f64 + s as f64 * 3.0,
                        j as f64,
                        ((i * j + s) % 3) as f64 * 0.3,
                    )
                })
            });
            let mut g = PatchF64::from_bezier(&b);
            g.cv[3].z += 0.4;
            g.cv[13].x -= 0.2;
            g
        })
        .collect();
    let pts: Vec<[f32; 4]> = patches
        .iter()
        .flat_map(|p| {
            p.cv.iter()
                .map(|c| [c.x as f32, c.y as f32, c.z as f32, 1.0])
        })
        .collect();
    let idx: Vec<u32> = (0..pts.len() as u32).collect();
    let pulled = vertex_pull(PatchKind::Gregory, &pts, &idx, patches.len() as u32, level);
    let computed = with_gpu(|ctx| {
        let pass = GregoryEvalPass::new(ctx).unwrap();
        let pb = storage(ctx, "points", bytemuck::cast_slice(&pts));
        let ib = storage(ctx, "patch points", bytemuck::cast_slice(&idx));
        let fb = storage(
            ctx,
            "flags",
            bytemuck::cast_slice(&vec![0u32; patches.len()]),
        );
        let out = output(
            ctx,
            "vertices",
            vertex_count(patches.len() as u32, level) * 32,
        );
        ctx.one_shot(|cmd| {
            pass.record(
                ctx,
                cmd,
                gregvox::passes::gregory_eval::ControlPoints::plain(&pb),
                &ib,
                &fb,
                patches.len() as u32,
                level,
                false,
                &out,
            )
        })
        .unwrap();
        ctx.read_pod::<SurfaceVertex>(&out).unwrap()
    });
    let (dp, dn) = max_diff(&pulled, &computed);
    eprintln!("gregory: vertex-pull vs compute |Δp| {dp:.2e}, |Δn| {dn:.2e}");
    assert!(dp <= 1e-6 * 25.0 && dn <= 1e-5, "{dp} {dn}");
}

#[test]
fn malformed_beziex_files_give_clear_errors() {
    let dir = std::env::temp_dir().join(format!("gregvox-beziex-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cases = [
        ("garbage.gzjson", &b"\x1f\x8b\x08\x00garbage"[..], "gzip"),
        ("empty.json", &b"{\"surface\": []}"[..], "no patches"),
        ("short.json", &b"{\"surface\": [{\"vertex\": [0,0,0], \"surfaceEdge\": {\"bez00\": [], \"bez01\": [], \"bez10\": [], \"bez11\": []}}]}"[..], "vertex has 3 numbers"),
        ("text.json", &b"hello"[..], "not a Beziex model"),
    ];
    for (name, bytes, needle) in cases {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        let err = load_beziex(&p).unwrap_err().to_string();
        assert!(err.contains(name) && err.contains(needle), "{err}");
    }
    assert!(load_beziex(dir.join("missing.gzjson"))
        .unwrap_err()
        .to_string()
        .contains("missing.gzjson"));
    let _ = std::fs::remove_dir_all(&dir);
}
