//! The demo's frames and the passes behind them, on lavapipe with validation (every test runs in
//! `common::with_gpu`: any validation message or leaked allocation fails it).
//!
//! - The curvature pass against the CPU's fundamental forms (`geom::curvature` via `PatchF64::curvature`).
//! - The shadow map against a CPU ray cast (`geom::shading::in_shadow_by`).
//! - Golden frames: a few fixed-time offscreen frames of every entry of [`FRAMES`] against PNGs in
//!   tests/fixtures/demo/ (regenerate with `BLESS=1 cargo test --test demo_golden`), rendered as the demo
//!   renders them (4× MSAA; `cage_msaa1` single-sampled), plus: frames are not blank, and animated scenes
//!   change between the sampled frames; MSAA changes only edge pixels, each to a value its single-sample
//!   neighbourhood spans.
//! - 1,000 frames with flat GPU memory; resize / minimise / restore; level changes and scene switches.
//! - The window under Xvfb with every key typed (`--keys`), no validation message, a screenshot written.
mod common;

use common::{differing, read_png};

use ash::vk;
use clap::Parser;
use glam::{DVec3, Mat4, Vec3, Vec4};
use gregvox::demo::{build_scene, draw_path, DemoArgs, Renderer, FRAMES_IN_FLIGHT};
use gregvox::engine::cage::{builtin_cage, cage_topology};
use gregvox::engine::gregory::GregorySurface;
use gregvox::geom::shading::in_shadow_by;
use gregvox::gpu::{Context, MemoryLocation, OffscreenTarget, PresentTarget};
use gregvox::passes::shadow_map::{light_view_proj, ShadowMap};
use gregvox::passes::surface_curvature::SurfaceCurvaturePass;
use gregvox::passes::surface_draw::{
    LitDraw, ShadingMode, SurfaceDrawPass, SurfacePush, FLAG_GROUND, FLAG_SHADOWS,
};
use gregvox::surface::Tangents;
use std::path::PathBuf;

// ---------------------------------------------------------------------------------------------------------
// Golden frames
// ---------------------------------------------------------------------------------------------------------

/// The golden table: (name, `gregvox demo` arguments, animated?). A new scene is one line here.
const FRAMES: &[(&str, &[&str], bool)] = &[
    ("flag", &["--scene", "flag"], true),
    (
        "flag_zebra",
        &["--scene", "flag", "--shading", "zebra"],
        true,
    ),
    ("flag_mean", &["--scene", "flag", "--shading", "mean"], true),
    (
        "flag_normals_pull",
        &["--scene", "flag", "--shading", "normals", "--vertex-pull"],
        true,
    ),
    ("cage", &["--scene", "cage"], true),
    ("cage_msaa1", &["--scene", "cage", "--msaa", "1"], true),
    ("cage_hud", &["--scene", "cage", "--hud"], true),
    ("cage_mean", &["--scene", "cage", "--shading", "mean"], true),
    (
        "cage_gaussian",
        &["--scene", "cage", "--shading", "gaussian"],
        true,
    ),
    (
        "cage_wireframe_pull",
        &["--scene", "cage", "--shading", "wireframe", "--vertex-pull"],
        true,
    ),
    ("spinner", &["--scene", "spinner"], true),
    (
        "cage_adaptive",
        &[
            "--scene",
            "cage",
            "--adaptive",
            "4",
            "--level",
            "16",
            "--shading",
            "zebra",
        ],
        true,
    ),
    ("voxels", &["--scene", "voxels", "--voxel-res", "32"], true),
    ("curves", &["--scene", "curves"], true),
    ("beziex", &["--scene", "beziex"], true),
];

/// Frame size of the golden images: small enough to commit, large enough to show the shading.
const SIZE: (u32, u32) = (160, 120);
/// Fixed time step and the frames compared: t = 0 and t = 0.8 s.
const TIME_STEP: f32 = 1.0 / 30.0;
const SAMPLED: [u64; 2] = [0, 24];

/// Tolerance: lavapipe renders the same frame bit for bit on one machine, but LLVM version, CPU features
/// (vector width of the JIT) and f32 evaluation order may move a few edge pixels between machines: at most
/// 0.5 % of the pixels may differ by more than 8/255 in some channel.
const MAX_DIFFERING: f64 = 0.005;
const CHANNEL_SLACK: u8 = 8;

#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    demo: DemoArgs,
}

fn demo_args(extra: &[&str]) -> DemoArgs {
    let size = format!("{}x{}", SIZE.0, SIZE.1);
    let mut argv = vec!["demo", "--offscreen", "--size", &size];
    argv.extend_from_slice(extra);
    Cli::try_parse_from(argv)
        .expect("valid demo arguments")
        .demo
}

/// Renders frames 0..=max(wanted) at the fixed time step (`--time-step`, else [`TIME_STEP`]); returns the RGBA8 pixels of the wanted frames.
fn render(ctx: &Context, args: &DemoArgs, wanted: &[u64]) -> Vec<Vec<u8>> {
    let (w, h) = args.size;
    let mut target = OffscreenTarget::new(ctx, w, h, FRAMES_IN_FLIGHT).unwrap();
    // As `gregvox demo` renders: multisampled as `--msaa` asks (4 by default) where the device has it.
    let samples = gregvox::demo::frame_samples(ctx, args);
    let format = gregvox::passes::draw::ColorTarget {
        format: target.format(),
        samples,
    };
    let scene = build_scene(ctx, args, format).unwrap();
    let mut r = Renderer::new(ctx, scene, args.shading, draw_path(args)).unwrap();
    r.samples = samples;
    // The overlay as `--hud` draws it, its times (which change from run to run) shown as "-".
    r.hud = args.hud;
    r.hud_times = false;
    let dt = args.time_step.unwrap_or(TIME_STEP);
    let mut out = Vec::new();
    for f in 0..=*wanted.iter().max().unwrap() {
        let begun = r.begin_frame(ctx).unwrap();
        let slot = begun.0;
        assert!(r.draw(ctx, begun, &mut target, f as f32 * dt).unwrap());
        if wanted.contains(&f) {
            r.frames.wait_all(ctx).unwrap();
            out.push(target.read_rgba(slot).unwrap());
        }
    }
    out
}

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/demo")
        .join(name)
}

/// Fraction of pixels that are not (within 8/255) the frame's most common colour.
fn non_background(px: &[u8]) -> f64 {
    let mut counts = std::collections::HashMap::new();
    for p in px.chunks_exact(4) {
        *counts.entry([p[0], p[1], p[2]]).or_insert(0usize) += 1;
    }
    let (mode, _) = counts.into_iter().max_by_key(|&(_, c)| c).unwrap();
    let bg: Vec<u8> = px
        .chunks_exact(4)
        .flat_map(|_| [mode[0], mode[1], mode[2], 255])
        .collect();
    differing(px, &bg, CHANNEL_SLACK)
}

#[test]
fn golden_frames_of_every_scene_match_within_tolerance() {
    let bless = std::env::var("BLESS").is_ok_and(|v| v == "1");
    let mut failures = Vec::new();
    common::with_gpu(|ctx| {
        for &(name, extra, animated) in FRAMES {
            let frames = render(ctx, &demo_args(extra), &SAMPLED);
            for (px, f) in frames.iter().zip(SAMPLED) {
                let shown = non_background(px);
                let path = fixture(&format!("{name}_f{f:03}.png"));
                if bless {
                    // A golden must show something to be worth keeping (the thinnest, `curves`, ~5.6 %).
                    assert!(
                        shown > 0.01,
                        "{name} frame {f}: only {:.2} % of the pixels show anything",
                        100.0 * shown
                    );
                    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
                    gregvox::gpu::present::write_png_rgba(&path, SIZE.0, SIZE.1, px).unwrap();
                    continue;
                }
                let (w, h, golden) = read_png(&path);
                assert_eq!((w, h), SIZE, "{}", path.display());
                // "Not blank" relative to the golden's own content, not a fixed share of the frame: a
                // scene of thin lines (curves) is as strictly held as one that fills the frame. The frame
                // may lose no more content than the pixel tolerance lets move.
                let expected = non_background(&golden);
                assert!(
                    shown >= expected - MAX_DIFFERING,
                    "{name} frame {f}: {:.2} % of the pixels show anything, the golden {:.2} %",
                    100.0 * shown,
                    100.0 * expected
                );
                let d = differing(px, &golden, CHANNEL_SLACK);
                if d > MAX_DIFFERING {
                    // Beside the test's temporary files, not the fixtures: a failure leaves the tree clean.
                    let got = std::env::temp_dir().join(format!("gregvox-{name}_f{f:03}.got.png"));
                    let _ = gregvox::gpu::present::write_png_rgba(&got, w, h, px);
                    failures.push(format!(
                        "{name} frame {f}: {:.2} % of the pixels differ (> {} %); see {}",
                        100.0 * d,
                        100.0 * MAX_DIFFERING,
                        got.display()
                    ));
                }
            }
            if animated {
                let change = differing(&frames[0], &frames[1], CHANNEL_SLACK);
                assert!(
                    change > 0.01,
                    "{name}: frames {} and {} differ in only {:.2} % of the pixels",
                    SAMPLED[0],
                    SAMPLED[1],
                    100.0 * change
                );
            }
        }
    });
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn msaa_averages_the_edges_and_changes_nothing_else() {
    // Lavapipe has 4× for colour and depth; the resolve averages each pixel's samples, so a pixel that
    // changes from the single-sample frame lies on an edge: its colour is within the range of the
    // single-sample pixels around it, which are what the samples saw.
    common::with_gpu(|ctx| {
        let l = &ctx.limits;
        let has = l.framebuffer_color_sample_counts & l.framebuffer_depth_sample_counts;
        assert!(has.contains(vk::SampleCountFlags::TYPE_4), "{has:?}");
        // Lines rasterize differently multisampled (rectangles of the line's width instead of one pixel a
        // step), so the neighbourhood bound holds for surfaces; for the curves only the counts.
        for (scene, surfaces) in [("cage", true), ("curves", false)] {
            let one = &render(ctx, &demo_args(&["--scene", scene, "--msaa", "1"]), &[3])[0];
            let four = &render(ctx, &demo_args(&["--scene", scene, "--msaa", "4"]), &[3])[0];
            let (w, h) = (SIZE.0 as i64, SIZE.1 as i64);
            let px = |img: &[u8], x: i64, y: i64, c: usize| img[((y * w + x) * 4) as usize + c];
            let (mut changed, mut outside) = (0, 0);
            for y in 0..h {
                for x in 0..w {
                    if (0..3).all(|c| px(one, x, y, c) == px(four, x, y, c)) {
                        continue;
                    }
                    changed += 1;
                    let within = (0..3).all(|c| {
                        let near = (-1..=1)
                            .flat_map(|dy| (-1..=1).map(move |dx| (x + dx, y + dy)))
                            .filter(|&(u, v)| u >= 0 && v >= 0 && u < w && v < h)
                            .map(|(u, v)| px(one, u, v, c));
                        let (lo, hi) = near.fold((255u8, 0u8), |(a, b), p| (a.min(p), b.max(p)));
                        let got = px(four, x, y, c);
                        got + 3 >= lo && got <= hi.saturating_add(3)
                    });
                    if !within {
                        outside += 1;
                    }
                }
            }
            let n = (w * h) as f64;
            assert!(
                changed as f64 > 0.002 * n,
                "{scene}: only {changed} pixels smoothed"
            );
            assert!(
                (changed as f64) < 0.15 * n,
                "{scene}: {changed} pixels changed"
            );
            // Shading varies inside a pixel too (the lit surface, the zebra): allow a few.
            assert!(
                !surfaces || (outside as f64) < 0.01 * changed as f64 + 4.0,
                "{scene}: {outside} of {changed} changed pixels outside their neighbourhood's range"
            );
        }
    });
}

#[test]
fn a_paused_scene_renders_the_same_frame_at_every_time() {
    // --time-step 0 freezes time: the fixed-time mode is what makes the golden frames reproducible.
    common::with_gpu(|ctx| {
        let frames = render(
            ctx,
            &demo_args(&["--scene", "flag", "--time-step", "0"]),
            &[0, 1, 5],
        );
        assert!(
            frames[0] == frames[1] && frames[1] == frames[2],
            "same time, same pixels (bit for bit)"
        );
    });
}

#[test]
fn a_thousand_frames_keep_gpu_memory_flat() {
    common::with_gpu(|ctx| {
        let args = demo_args(&["--scene", "cage", "--shading", "mean"]);
        let mut target = OffscreenTarget::new(ctx, 64, 48, FRAMES_IN_FLIGHT).unwrap();
        let scene = build_scene(ctx, &args, target.format()).unwrap();
        let mut r = Renderer::new(ctx, scene, args.shading, draw_path(&args)).unwrap();
        let mut after_warmup = None;
        for f in 0..1000u64 {
            let begun = r.begin_frame(ctx).unwrap();
            r.draw(ctx, begun, &mut target, f as f32 / 60.0).unwrap();
            if f == 10 {
                after_warmup = Some((ctx.allocated_bytes(), ctx.live_allocations().len()));
            }
        }
        r.finish(ctx).unwrap();
        let end = (ctx.allocated_bytes(), ctx.live_allocations().len());
        assert_eq!(
            Some(end),
            after_warmup,
            "(bytes, allocations) after frame 10 and after frame 1000"
        );
    });
}

#[test]
fn resize_minimise_and_restore_between_frames() {
    // The window's events through the same renderer and a target that is resized like a swapchain: a new
    // size, 0×0 (minimised: frames are skipped, nothing drawn), then the first size again.
    common::with_gpu(|ctx| {
        let args = demo_args(&["--scene", "cage"]);
        let mut target = OffscreenTarget::new(ctx, 64, 48, FRAMES_IN_FLIGHT).unwrap();
        let scene = build_scene(ctx, &args, target.format()).unwrap();
        let mut r = Renderer::new(ctx, scene, args.shading, draw_path(&args)).unwrap();
        let mut t = 0.0;
        let mut frame = |r: &mut Renderer, target: &mut OffscreenTarget| -> bool {
            t += 1.0 / 60.0;
            let begun = r.begin_frame(ctx).unwrap();
            r.draw(ctx, begun, target, t).unwrap()
        };
        for _ in 0..4 {
            assert!(frame(&mut r, &mut target));
        }
        r.finish(ctx).unwrap();
        let before = ctx.allocated_bytes();
        let steps: [((u32, u32), bool); 3] = [((96, 40), true), ((0, 0), false), ((64, 48), true)];
        for ((w, h), drawn) in steps {
            target.resize(vk::Extent2D {
                width: w,
                height: h,
            });
            for _ in 0..4 {
                assert_eq!(frame(&mut r, &mut target), drawn, "{w}×{h}");
            }
            assert_eq!(
                target.extent(),
                vk::Extent2D {
                    width: w,
                    height: h
                }
            );
        }
        r.finish(ctx).unwrap();
        // Depth images follow the target lazily, one slot at a time: after a full round at the first size
        // every buffer and image is back to its old size.
        assert_eq!(
            ctx.allocated_bytes(),
            before,
            "bytes after restoring the size"
        );
        let px = target.read_rgba(0).unwrap();
        assert_eq!(px.len(), 64 * 48 * 4);
        assert!(
            non_background(&px) > 0.05,
            "the restored frame shows the scene"
        );
    });
}

#[test]
fn level_changes_and_scene_switches_rebuild_in_place() {
    // What the +/− and number keys do in the window, through the renderer: the level changes the surface's
    // buffers (device idle), a scene switch replaces the scene; frames keep coming, with no validation message.
    common::with_gpu(|ctx| {
        let args = demo_args(&["--scene", "flag"]);
        let mut target = OffscreenTarget::new(ctx, 64, 48, FRAMES_IN_FLIGHT).unwrap();
        let scene = build_scene(ctx, &args, target.format()).unwrap();
        let mut r = Renderer::new(ctx, scene, args.shading, draw_path(&args)).unwrap();
        let frames = |r: &mut Renderer, target: &mut OffscreenTarget| {
            for f in 0..3 {
                let begun = r.begin_frame(ctx).unwrap();
                assert!(r.draw(ctx, begun, target, f as f32 / 60.0).unwrap());
            }
        };
        frames(&mut r, &mut target);
        for scene in ["flag", "cage"] {
            if scene != "flag" {
                let next = build_scene(ctx, &demo_args(&["--scene", scene]), target.format());
                r.replace_scene(ctx, next.unwrap()).unwrap();
                frames(&mut r, &mut target);
            }
            let level = r.scene.level().expect("Gregory scenes have a level");
            assert!(r.set_level(ctx, level + 1).unwrap(), "{scene}");
            assert_eq!(r.scene.level(), Some(level + 1), "{scene}");
            frames(&mut r, &mut target);
            assert!(r.set_level(ctx, 1).unwrap(), "{scene}");
            frames(&mut r, &mut target);
        }
        r.finish(ctx).unwrap();
        let px = target.read_rgba(0).unwrap();
        assert!(non_background(&px) > 0.05, "the cage at level 1 shows");
    });
}

#[test]
fn every_key_works_in_a_window_under_xvfb() {
    // The windowed path end to end: the binary under Xvfb (a system package, see .ci/run) types every
    // control with --keys, one every 5 frames; the scripted keys go through the same `key_action` as real ones.
    // Then the window operations: a resize (the swapchain is rebuilt and a screenshot taken at the new size),
    // minimise (frames are skipped) and restore.
    let dir = std::env::temp_dir().join(format!("gregvox-window-keys-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let keys: Vec<String> =
        "s,s,s,s,s,+,-,v,Space,p,t,d,v,Space,1,c,3,2,h,h,resize:200x150,minimize,restore,p"
            .split(',')
            .map(String::from)
            .collect();
    let err = common::run_demo_window(
        &["--frames", "140", "--size", "160x120", "--scene", "cage"],
        &keys,
        &dir,
    );
    for said in [
        "shading Normals",
        "shading Gaussian",
        "level 9",
        "level 8",
        "VertexPull path",
        "screenshot",
        "| pass |",
        "scene flag",
        "scene spinner",
        "scene built-in box cage",
        "presenting at 200x150",
        "overlay off",
        "overlay on",
        "140 frames presented, 1 skipped",
    ] {
        assert!(err.contains(said), "no '{said}' in:\n{err}");
    }
    let shot = dir.join("gregvox-screenshot-001.png");
    let (w, h, px) = read_png(&shot);
    assert_eq!((w, h), (160, 120));
    assert!(non_background(&px) > 0.05, "the screenshot shows the scene");
    let (w, h, px) = read_png(&dir.join("gregvox-screenshot-002.png"));
    assert_eq!(
        (w, h),
        (200, 150),
        "the second screenshot comes from the resized swapchain"
    );
    assert!(
        non_background(&px) > 0.05,
        "the scene shows after minimise and restore"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

// ---------------------------------------------------------------------------------------------------------
// The passes behind the frames
// ---------------------------------------------------------------------------------------------------------

#[test]
fn curvature_pass_matches_the_cpu_fundamental_forms_at_every_grid_vertex() {
    const LEVEL: u32 = 6;
    let mesh = builtin_cage(4, 2, 2);
    let (topo, cage, _) = cage_topology(&mesh, Tangents::OpenSubdiv).unwrap();
    let (gpu, points) = common::with_gpu(|ctx| {
        let surface = GregorySurface::new(ctx, &topo, &cage, LEVEL).unwrap();
        let pass = SurfaceCurvaturePass::new(ctx).unwrap();
        let n = surface.patch_count() as u64 * (LEVEL as u64 + 1).pow(2);
        let out = ctx
            .create_buffer(
                "curvature",
                n * 8,
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::GpuOnly,
            )
            .unwrap();
        ctx.one_shot(|cmd| {
            surface.record(ctx, cmd, None, None)?;
            pass.record(
                ctx,
                cmd,
                surface.points(),
                surface.patch_points(),
                surface.patch_count(),
                LEVEL,
                &out,
            )
        })
        .unwrap();
        let hk: Vec<[f32; 2]> = ctx.read_pod(&out).unwrap();
        let points = surface.read_points(ctx).unwrap();
        (hk, points)
    });
    let (worst, checked, singular) = common::assert_curvature_matches_cpu(
        "curvature pass",
        &topo.patch_points,
        &points,
        LEVEL,
        &gpu,
    );
    eprintln!(
        "curvature: {checked} vertices, {singular} singular, worst relative error {worst:.2e}"
    );
}

/// The shadow scene: a unit square occluder at z = 1 over a 4 × 4 ground at z = 0, a directional light
/// along (0.5, 0, 1), seen from straight above with an orthographic camera.
#[test]
fn shadow_map_darkens_exactly_the_ground_the_cpu_ray_cast_puts_in_shadow() {
    const W: u32 = 128;
    const H: u32 = 128;
    let light_dir = Vec3::new(0.5, 0.0, 1.0).normalize();
    let quad = |half: f32, z: f32| -> Vec<[f32; 8]> {
        [(-half, -half), (half, -half), (half, half), (-half, half)]
            .iter()
            .map(|&(x, y)| [x, y, z, 1.0, 0.0, 0.0, 1.0, 0.0])
            .collect()
    };
    let mut proj = Mat4::orthographic_rh(-2.0, 2.0, -2.0, 2.0, 0.1, 10.0);
    proj.y_axis.y = -proj.y_axis.y;
    let view_proj = proj * Mat4::look_at_rh(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y);
    let pixels = common::with_gpu(|ctx| {
        let draw = SurfaceDrawPass::new(ctx, common::FRAME_FORMAT, vk::Format::D32_SFLOAT).unwrap();
        let shadow = ShadowMap::new(ctx, 1024).unwrap();
        let up = |name: &str, bytes: &[u8], usage| ctx.upload_buffer(name, bytes, usage).unwrap();
        let idx: [u32; 6] = [0, 1, 2, 0, 2, 3];
        let ground_v = up(
            "ground",
            bytemuck::cast_slice(&quad(2.0, 0.0)),
            vk::BufferUsageFlags::VERTEX_BUFFER,
        );
        let occ_v = up(
            "occluder",
            bytemuck::cast_slice(&quad(0.5, 1.0)),
            vk::BufferUsageFlags::VERTEX_BUFFER,
        );
        let ib = up(
            "indices",
            bytemuck::cast_slice(&idx),
            vk::BufferUsageFlags::INDEX_BUFFER,
        );
        let push = |flags: u32| SurfacePush {
            view_proj: view_proj.to_cols_array_2d(),
            eye: [0.0, 0.0, 5.0, 1.0],
            light: [light_dir.x, light_dir.y, light_dir.z, 0.35],
            color: [0.8, 0.8, 0.8, 1.0],
            mode: [ShadingMode::Phong as u32, 1, 0, flags],
        };
        common::render_frame(ctx, W, H, |cmd, target| {
            shadow.record(
                ctx,
                cmd,
                light_view_proj(light_dir, Vec3::ZERO, 2.5),
                &[LitDraw {
                    vertices: &occ_v,
                    curvature: None,
                    uvs: None,
                    indices: &ib,
                    index_count: 6,
                    indirect: None,
                }],
            );
            let lit = |v| LitDraw {
                vertices: v,
                curvature: None,
                uvs: None,
                indices: &ib,
                index_count: 6,
                indirect: None,
            };
            draw.record_lit(
                ctx,
                cmd,
                target,
                Some([0.0, 0.0, 0.0, 1.0]),
                &shadow,
                &[
                    (lit(&ground_v), push(FLAG_GROUND | FLAG_SHADOWS)),
                    (lit(&occ_v), push(FLAG_SHADOWS)),
                ],
            );
            Ok(())
        })
    });
    let inv = view_proj.inverse();
    let occluder_hit = |o: DVec3, d: DVec3| -> Vec<f64> {
        // The occluder's plane z = 1, inside the unit square.
        if d.z.abs() < 1e-12 {
            return Vec::new();
        }
        let t = (1.0 - o.z) / d.z;
        let p = o + d * t;
        if p.x.abs() <= 0.5 && p.y.abs() <= 0.5 {
            vec![t]
        } else {
            Vec::new()
        }
    };
    // Margin around the shadow's edge: one pixel (4/128) plus two shadow texels (5/1024), rounded up.
    let margin = 0.05;
    let (mut shadowed, mut lit) = (0, 0);
    for py in 0..H {
        for px in 0..W {
            let ndc = Vec4::new(
                2.0 * (px as f32 + 0.5) / W as f32 - 1.0,
                2.0 * (py as f32 + 0.5) / H as f32 - 1.0,
                0.5,
                1.0,
            );
            let w = inv * ndc;
            let (x, y) = ((w.x / w.w) as f64, (w.y / w.w) as f64);
            if x.abs() <= 0.5 + margin && y.abs() <= 0.5 + margin {
                continue; // the occluder itself (and its edge)
            }
            // Where the light ray from this ground point crosses z = 1, relative to the square's edge.
            let ld = light_dir.as_dvec3();
            let (cx, cy) = (x + ld.x / ld.z, y + ld.y / ld.z);
            let edge = (cx.abs() - 0.5).abs().min((cy.abs() - 0.5).abs());
            if edge < margin {
                continue;
            }
            let p = DVec3::new(x, y, 0.0);
            let expect_shadow = in_shadow_by(p, DVec3::Z, p + ld * 1e3, 1e-4, occluder_hit);
            let r = pixels[((py * W + px) * 4) as usize];
            // Lit ground: 0.8·(ambient 0.0525 + 0.75·n·l + specular) ≈ 150/255; in shadow 0.8·0.0525 ≈ 11/255.
            let dark = r < 70;
            assert_eq!(
                dark, expect_shadow,
                "pixel ({px}, {py}) = ground ({x:.3}, {y:.3}): red {r}, CPU says shadow = {expect_shadow}"
            );
            if expect_shadow {
                shadowed += 1;
            } else {
                lit += 1;
            }
        }
    }
    // The shadow is the square shifted by 0.5 in x: half of it shows beside the occluder.
    assert!(
        shadowed > 300 && lit > 5000,
        "shadowed {shadowed}, lit {lit}"
    );
}

#[test]
fn the_checker_shading_shows_the_cages_own_uvs() {
    // `--shading checker` on a cage with UVs (vt) draws a checker over the UV surface the device evaluates
    // beside the positions; the same cage without its vt shows the checker over the patch parameters
    // instead: the two frames differ where the UVs do, and both hold the checker's light and dark squares.
    common::with_gpu(|ctx| {
        let model = format!(
            "{}/assets/models/opensubdiv/catmark_fvar_bound1.obj",
            env!("CARGO_MANIFEST_DIR")
        );
        let text = std::fs::read_to_string(&model).unwrap();
        // The same cage without UVs: vt lines dropped, f corners reduced to their vertex index.
        let plain: String = text
            .lines()
            .filter(|l| !l.starts_with("vt"))
            .map(|l| {
                if let Some(rest) = l.strip_prefix("f ") {
                    let corners: Vec<&str> = rest
                        .split_whitespace()
                        .map(|t| t.split('/').next().unwrap())
                        .collect();
                    format!("f {}\n", corners.join(" "))
                } else {
                    format!("{l}\n")
                }
            })
            .collect();
        let plain_path =
            std::env::temp_dir().join(format!("gregvox-checker-{}.obj", std::process::id()));
        std::fs::write(&plain_path, plain).unwrap();
        let frame = |m: &str, shading: &str| {
            let args = demo_args(&[
                "--scene",
                "cage",
                "--model",
                m,
                "--shading",
                shading,
                "--deform",
                "none",
            ]);
            render(ctx, &args, &[0]).remove(0)
        };
        let with_uv = frame(&model, "checker");
        let without = frame(plain_path.to_str().unwrap(), "checker");
        let phong = frame(&model, "phong");
        let _ = std::fs::remove_file(&plain_path);
        let differing = |a: &[u8], b: &[u8]| {
            a.chunks_exact(4)
                .zip(b.chunks_exact(4))
                .filter(|(p, q)| p.iter().zip(q.iter()).any(|(x, y)| x.abs_diff(*y) > 24))
                .count() as f64
                / (a.len() / 4) as f64
        };
        let d_uv = differing(&with_uv, &without);
        let d_phong = differing(&with_uv, &phong);
        eprintln!("checker with UVs vs patch parameters: {d_uv:.3}; vs phong: {d_phong:.3}");
        assert!(d_uv > 0.02, "the cage's UVs change the checker ({d_uv})");
        assert!(d_phong > 0.02, "the checker is drawn ({d_phong})");
        // Light and dark squares: luminance spread over the frame.
        let lum: Vec<u32> = with_uv
            .chunks_exact(4)
            .map(|p| p[0] as u32 + p[1] as u32 + p[2] as u32)
            .collect();
        let dark = lum.iter().filter(|&&l| l < 200).count();
        assert!(
            dark > lum.len() / 50,
            "dark squares: {dark} of {}",
            lum.len()
        );
    });
}
