//! Specification of the demo's voxels, curves and beziex scenes:
//! - the compute ray caster agrees with the CPU 3D-DDA reference (`voxel::raycast`) pixel for pixel on fixed
//!   grids — same hit/miss mask, same hit voxel except on a bounded number of edge-grazing rays, colours
//!   within 1/255;
//! - the voxels scene's resident grid after one frame is bit-for-bit the one-shot GPU voxelizer's grid of the
//!   same surface in the same frame;
//! - every new scene renders offscreen to a non-blank picture, the animated ones change between frames, and
//!   the curves scene draws exactly the vertex count its construction predicts.
mod common;

use ash::vk;
use clap::Parser;
use common::with_gpu;
use glam::{DVec2, Vec3};
use gregvox::demo::curves::{casteljau_t, curve_lines, expected_vertices, CurvesScene};
use gregvox::demo::scene::{DrawPath, FrameTargets, Scene, ViewState};
use gregvox::demo::voxels::{VoxelsOptions, VoxelsScene};
use gregvox::demo::{build_scene, DemoArgs, Renderer, FRAMES_IN_FLIGHT};
use gregvox::engine::cage::{builtin_cage, cage_topology};
use gregvox::engine::gregory::GregorySurface;
use gregvox::engine::voxelize::{voxelize_gregory_surface, PeelVoxelizer};
use gregvox::geom::bezier::Bezier;
use gregvox::gpu::present::begin_color_target;
use gregvox::gpu::resources::image_barrier;
use gregvox::gpu::{Context, Image, ImageDesc, MemoryLocation, OffscreenTarget, Profiler};
use gregvox::passes::cage_deform::Deformation;
use gregvox::passes::peel::PeelGeometry;
use gregvox::passes::surface_draw::ShadingMode;
use gregvox::passes::voxel_raycast::{bricks_bytes, ids_bytes, VoxelRaycastPass};
use gregvox::surface::Tangents;
use gregvox::voxel::cpu::FillRule;
use gregvox::voxel::grid::{Axis, GridFrame, GridSpec, VoxelGrid};
use gregvox::voxel::raycast::{raycast_grid, RayCamera, RayShading, MISS};

const FORMAT: vk::Format = vk::Format::B8G8R8A8_UNORM;

fn shading() -> RayShading {
    RayShading {
        light: Vec3::new(0.4, -0.5, 0.8).normalize().to_array(),
        ambient: 0.3,
        color: [0.3, 0.55, 0.85],
        background: [0.1, 0.1, 0.12],
    }
}

/// Two cameras looking at the grid's centre from oblique directions (no ray runs along a grid plane).
fn cameras(frame: &GridFrame, aspect: f32) -> Vec<RayCamera> {
    let side = (frame.voxel_size[0] * frame.dims[0] as f64) as f32;
    let c = Vec3::from_array(frame.origin.map(|x| x as f32)) + Vec3::splat(0.5 * side);
    [
        Vec3::new(0.8, -0.55, 0.45),
        Vec3::new(-0.3, 0.7, -0.6),
        Vec3::new(0.0, -1.0, 0.0),
    ]
    .iter()
    .map(|d| RayCamera::look_at(c + 2.2 * side * d.normalize(), c, Vec3::Z, 0.8, aspect))
    .collect()
}

/// The GPU ray cast of `grid` (any bit axis; re-laid along z) as (voxel id, rgba) per pixel.
fn gpu_raycast(
    ctx: &Context,
    grid: &VoxelGrid,
    cam: &RayCamera,
    w: u32,
    h: u32,
    s: &RayShading,
) -> Vec<(u32, [u8; 4])> {
    let z = grid.to_axis(Axis::Z);
    let pass = VoxelRaycastPass::new(ctx, FORMAT).unwrap();
    let buf = ctx
        .upload_buffer(
            "test grid",
            bytemuck::cast_slice(&z.words),
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )
        .unwrap();
    let image = VoxelRaycastPass::create_image(ctx, "test raycast", w, h).unwrap();
    let bricks = ctx
        .create_buffer(
            "test bricks",
            bricks_bytes(z.frame.dims[0]),
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuOnly,
        )
        .unwrap();
    let ids = ctx
        .create_buffer(
            "test ids",
            ids_bytes(w, h),
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )
        .unwrap();
    ctx.one_shot(|cmd| {
        pass.record(
            ctx,
            cmd,
            &buf,
            &bricks,
            &z.frame,
            &image,
            Some(&ids),
            cam,
            s,
        )
    })
    .unwrap();
    let words: Vec<u32> = ctx.read_pod(&ids).unwrap();
    words
        .chunks_exact(2)
        .map(|p| (p[0], p[1].to_le_bytes()))
        .collect()
}

fn single_voxel() -> VoxelGrid {
    let frame = GridFrame::cubic(8, [-1.0, 0.5, 2.0], 4.0);
    let mut g = VoxelGrid::empty(frame, Axis::Z);
    g.set(3, 4, 5, true);
    g
}

fn sphere() -> VoxelGrid {
    let frame = GridFrame::cubic(32, [0.0; 3], 2.0);
    let mut g = VoxelGrid::empty(frame, Axis::X);
    for k in 0..32 {
        for j in 0..32 {
            for i in 0..32 {
                let c = frame.centre(i, j, k);
                let r2: f64 = c.iter().map(|x| (x - 1.0) * (x - 1.0)).sum();
                g.set(i, j, k, r2 <= 0.8 * 0.8);
            }
        }
    }
    g
}

fn cube() -> VoxelGrid {
    let frame = GridFrame::cubic(8, [0.0; 3], 1.0);
    let mut g = VoxelGrid::empty(frame, Axis::Z);
    for w in g.words.iter_mut() {
        *w = 0xff; // 8 bits per column: every voxel solid
    }
    g
}

fn builtin_surface(ctx: &Context, level: u32) -> GregorySurface {
    let (topo, cage, _) = cage_topology(&builtin_cage(4, 2, 2), Tangents::OpenSubdiv).unwrap();
    GregorySurface::new(ctx, &topo, &cage, level).unwrap()
}

fn gregory_grid(ctx: &Context) -> VoxelGrid {
    let surface = builtin_surface(ctx, 6);
    ctx.one_shot(|cmd| surface.record(ctx, cmd, None, None))
        .unwrap();
    let (grid, _) = voxelize_gregory_surface(
        ctx,
        &surface,
        &GridSpec::res(32),
        &[Axis::Z],
        FillRule::Winding,
        64,
        None,
    )
    .unwrap();
    grid
}

#[test]
fn the_compute_ray_caster_matches_the_cpu_3d_dda_on_fixed_grids() {
    with_gpu(|ctx| {
        let (w, h) = (160, 120);
        let s = shading();
        let grids = [
            ("single voxel", single_voxel()),
            ("sphere R=32", sphere()),
            ("cube R=8", cube()),
            ("Gregory surface R=32", gregory_grid(ctx)),
        ];
        for (name, grid) in &grids {
            assert!(grid.count() > 0, "{name}: empty grid");
            for (c, cam) in cameras(&grid.frame, w as f32 / h as f32).iter().enumerate() {
                let cpu = raycast_grid(grid, cam, w, h, &s);
                let gpu = gpu_raycast(ctx, grid, cam, w, h, &s);
                let mut mask_diff = 0;
                let mut voxel_diff = 0;
                let mut worst = 0u8;
                let mut hits = 0;
                for (p, (a, b)) in cpu.iter().zip(&gpu).enumerate() {
                    if (a.voxel == MISS) != (b.0 == MISS) {
                        mask_diff += 1;
                        eprintln!("{name} cam {c}: pixel {p} cpu {:?} gpu {:?}", a, b);
                        continue;
                    }
                    if a.voxel == MISS {
                        assert_eq!(a.rgba, b.1, "{name}: background differs at pixel {p}");
                        continue;
                    }
                    hits += 1;
                    if a.voxel != b.0 {
                        voxel_diff += 1;
                        continue;
                    }
                    for ch in 0..4 {
                        worst = worst.max(a.rgba[ch].abs_diff(b.1[ch]));
                    }
                }
                eprintln!(
                    "{name} cam {c}: {hits} hits, mask differences {mask_diff}, other voxel {voxel_diff}, \
                     worst colour step {worst}"
                );
                assert!(hits > 0, "{name} cam {c}: the camera sees nothing");
                assert_eq!(mask_diff, 0, "{name} cam {c}: hit/miss masks differ");
                // Edge-grazing rays: a ray through (within f32 rounding of) a voxel edge or corner may step
                // into either neighbour first. The GPU evaluates the same f32 operations (no contraction), so
                // such ties are rare: at most 1 % of the hits.
                assert!(
                    voxel_diff * 100 <= hits,
                    "{name} cam {c}: {voxel_diff} of {hits} hits reach another voxel"
                );
                // One UNORM8 step: the shader quantizes with round() as the reference does.
                assert!(worst <= 1, "{name} cam {c}: colours differ by {worst}/255");
            }
        }
    });
}

/// Entry and exit of a ray with the unit cube cell `c` (grid units), or None.
fn cell_interval(o: [f32; 3], d: [f32; 3], c: [u32; 3]) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for a in 0..3 {
        let (o, d) = (o[a] as f64, d[a] as f64);
        let (lo, hi) = (c[a] as f64, c[a] as f64 + 1.0);
        if d.abs() < 1e-300 {
            if o < lo || o > hi {
                return None;
            }
            continue;
        }
        let (a0, a1) = ((lo - o) / d, (hi - o) / d);
        t0 = t0.max(a0.min(a1));
        t1 = t1.min(a0.max(a1));
    }
    (t1 >= t0.max(0.0)).then_some((t0.max(0.0), t1))
}

#[test]
fn the_cpu_dda_finds_the_nearest_solid_voxel_of_a_brute_force_search() {
    // Oracle: intersect the ray with every solid voxel (f64 slab tests) and take the nearest entry. Rays that
    // only graze the hit voxel (inside it for less than 1e-4 voxel) may legitimately go either way, and so may
    // two voxels entered at the same distance (a shared face or edge): those are compared by entry distance.
    let s = shading();
    for (name, grid) in [
        ("single voxel", single_voxel()),
        ("sphere R=32", sphere()),
        ("cube R=8", cube()),
    ] {
        let f = grid.frame;
        let (w, h) = (40, 30);
        let res = f.dims[0];
        let solid: Vec<[u32; 3]> = (0..res)
            .flat_map(|k| (0..res).flat_map(move |j| (0..res).map(move |i| [i, j, k])))
            .filter(|&[i, j, k]| grid.get(i, j, k))
            .collect();
        for cam in cameras(&f, w as f32 / h as f32) {
            let hits = raycast_grid(&grid, &cam, w, h, &s);
            let inv_pitch = 1.0 / f.voxel_size[0] as f32;
            let o: [f32; 3] =
                std::array::from_fn(|a| (cam.eye[a] - f.origin[a] as f32) * inv_pitch);
            let mut grazing = 0;
            for y in 0..h {
                for x in 0..w {
                    let d = gregvox::voxel::raycast::pixel_direction(&cam, x, y, w, h);
                    let best = solid
                        .iter()
                        .filter_map(|&c| cell_interval(o, d, c).map(|iv| (iv, c)))
                        .min_by(|a, b| a.0 .0.total_cmp(&b.0 .0));
                    let got = hits[(y * w + x) as usize].voxel;
                    match best {
                        None => assert_eq!(got, MISS, "{name}: pixel ({x}, {y}) hits nothing"),
                        Some(((t0, t1), c)) => {
                            if got == MISS {
                                assert!(
                                    t1 - t0 < 1e-4,
                                    "{name}: pixel ({x}, {y}) misses voxel {c:?}"
                                );
                                grazing += 1;
                                continue;
                            }
                            let r = f.dims[0];
                            let g = [got % r, (got / r) % r, got / (r * r)];
                            let (g0, _) =
                                cell_interval(o, d, g).expect("the hit voxel meets the ray");
                            assert!(grid.get(g[0], g[1], g[2]), "{name}: hit an empty voxel");
                            assert!(
                                (g0 - t0).abs() < 1e-4,
                                "{name}: pixel ({x}, {y}) hit {g:?} at {g0}, nearest {c:?} at {t0}"
                            );
                        }
                    }
                }
            }
            assert!(grazing <= 2, "{name}: {grazing} grazing rays");
        }
    }
}

/// Colour and depth images standing in for one frame of the renderer.
fn frame_images(ctx: &Context, w: u32, h: u32) -> (Image, Image) {
    let color = ctx
        .create_image(
            "test color",
            &ImageDesc::d2(
                w,
                h,
                FORMAT,
                vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
            ),
        )
        .unwrap();
    let depth = ctx
        .create_image(
            "test depth",
            &ImageDesc::d2(
                w,
                h,
                vk::Format::D32_SFLOAT,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            ),
        )
        .unwrap();
    (color, depth)
}

/// Records one frame of `scene` at time `t` into fresh images (slot 0) and waits for it.
fn one_frame(ctx: &Context, scene: &mut dyn Scene, t: f32) {
    let (w, h) = (160, 96);
    let (color, depth) = frame_images(ctx, w, h);
    let mut profiler = Profiler::new(ctx, 1, 64).unwrap();
    let view = ViewState {
        orbit: scene.framing(),
        shading: ShadingMode::Phong,
        animate: true,
        path: DrawPath::Compute,
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
                vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS
                    | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS,
                vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ
                    | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE,
            ),
        );
        let targets = FrameTargets {
            slot: 0,
            color: color.view(),
            depth: depth.view(),
            extent: vk::Extent2D {
                width: w,
                height: h,
            },
            resolve: None,
        };
        scene
            .record(ctx, cmd, &targets, t, &view, &mut profiler)
            .map_err(|e| gregvox::Error::Invalid(e.to_string()))
    })
    .unwrap();
}

#[test]
fn the_voxels_scene_grid_after_one_frame_equals_the_one_shot_gpu_voxelizer() {
    with_gpu(|ctx| {
        let surface = builtin_surface(ctx, 6);
        let mut scene = VoxelsScene::new(
            ctx,
            FORMAT,
            surface,
            VoxelsOptions {
                deformation: Deformation::Twist,
                res: 48,
                every: 1,
                scale: 1,
            },
            "built-in cage".into(),
        )
        .unwrap();
        // t = 1.3: a strongly twisted pose (sin t ≈ 0.96), not one of the planning samples.
        one_frame(ctx, &mut scene, 1.3);
        let resident = scene.voxelizer().read_grid(ctx).unwrap();
        let s = scene.surface();
        let geom = PeelGeometry {
            vertices: s.vertices(),
            indices: s.indices(),
            index_count: s.index_count(),
            bounds: None,
            mesh: None,
        };
        let one_shot = PeelVoxelizer::new(ctx, 32).unwrap();
        let (reference, stats) = one_shot
            .voxelize_axis(
                ctx,
                &geom,
                &scene.voxelizer().frame,
                Axis::Z,
                FillRule::Winding,
                None,
            )
            .unwrap();
        drop(one_shot);
        eprintln!(
            "resident grid: {} solid voxels of {}³, {} peeling passes planned, {} needed",
            resident.count(),
            resident.frame.dims[0],
            scene.voxelizer().layers,
            stats.layers
        );
        assert!(stats.layers <= scene.voxelizer().layers);
        assert!(resident.count() > 1000, "the grid is nearly empty");
        assert_eq!(resident.count_differences(&reference), 0);

        // Key D switches to the bend, replanning the grid; the next frame's grid again equals the one-shot one.
        assert!(scene.key(ctx, "d").unwrap());
        assert_eq!(scene.options.deformation, Deformation::Bend);
        one_frame(ctx, &mut scene, 1.3);
        let resident = scene.voxelizer().read_grid(ctx).unwrap();
        let s = scene.surface();
        let geom = PeelGeometry {
            vertices: s.vertices(),
            indices: s.indices(),
            index_count: s.index_count(),
            bounds: None,
            mesh: None,
        };
        let one_shot = PeelVoxelizer::new(ctx, 32).unwrap();
        let (reference, _) = one_shot
            .voxelize_axis(
                ctx,
                &geom,
                &scene.voxelizer().frame,
                Axis::Z,
                FillRule::Winding,
                None,
            )
            .unwrap();
        assert!(resident.count() > 1000);
        assert_eq!(resident.count_differences(&reference), 0);
    });
}

#[test]
fn with_voxel_every_2_the_grid_is_kept_on_the_odd_frames() {
    with_gpu(|ctx| {
        let surface = builtin_surface(ctx, 4);
        let mut scene = VoxelsScene::new(
            ctx,
            FORMAT,
            surface,
            VoxelsOptions {
                deformation: Deformation::Bend,
                res: 32,
                every: 2,
                scale: 2,
            },
            "built-in cage".into(),
        )
        .unwrap();
        let grids: Vec<VoxelGrid> = [0.0, 1.5, 1.5]
            .iter()
            .map(|&t| {
                one_frame(ctx, &mut scene, t);
                scene.voxelizer().read_grid(ctx).unwrap()
            })
            .collect();
        // Frame 1 (bent) shows frame 0's grid (rest pose); frame 2 voxelizes the bent pose.
        assert_eq!(grids[0], grids[1]);
        assert!(
            grids[2].count_differences(&grids[0]) > 100,
            "the bend changes the grid"
        );
    });
}

#[test]
fn the_curves_scene_draws_the_predicted_segments_from_the_geometry_core() {
    // The count is fixed by construction, whatever the time.
    for t in [0.0, 0.8, 2.5, 7.1] {
        let lines = curve_lines(t).unwrap();
        let parts: u32 = lines.parts.iter().map(|p| p.1).sum();
        assert_eq!(lines.vertices.len() as u32, expected_vertices(), "t = {t}");
        assert_eq!(2 * parts, expected_vertices(), "t = {t}");
        // The de Casteljau part ends with the cross marking the constructed point: its centre is the
        // Bernstein-form curve point B(s) (f32 vertices: 1e-5 relative to the 3-unit panel).
        let before: u32 = lines
            .parts
            .iter()
            .take_while(|p| p.0 != "bezier comb")
            .map(|p| p.1)
            .sum();
        let end = 2 * before as usize;
        let (a, b) = (lines.vertices[end - 2], lines.vertices[end - 1]);
        let centre = DVec2::new(
            0.5 * (a.position[0] + b.position[0]) as f64,
            0.5 * (a.position[2] + b.position[2]) as f64,
        );
        let ctrl: Vec<DVec2> = [
            (0.0, 0.0),
            (0.4, 1.8),
            (1.5, 2.2 + 0.3 * (0.7 * t as f64).sin()),
            (2.4, 0.2),
            (3.0, 1.4),
        ]
        .iter()
        .map(|&(x, y)| DVec2::new(x, y))
        .collect();
        let expect = Bezier::new(ctrl).unwrap().eval_bernstein(casteljau_t(t));
        assert!(
            (centre - expect).length() < 3e-5,
            "t = {t}: {centre} vs {expect}"
        );
    }
    with_gpu(|ctx| {
        let mut scene = CurvesScene::new(ctx, FORMAT).unwrap();
        one_frame(ctx, &mut scene, 0.4);
        assert_eq!(scene.drawn, expected_vertices());
    });
}

#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    demo: DemoArgs,
}

/// Renders `frames` frames of the scene `args` selects through the offscreen ring; returns the RGBA pixels of
/// the last two frames (oldest first).
fn render(ctx: &Context, args: &[&str], frames: u32) -> (u32, u32, Vec<Vec<u8>>) {
    let mut argv = vec!["demo"];
    argv.extend_from_slice(args);
    let cli = Cli::try_parse_from(argv).unwrap();
    let (w, h) = cli.demo.size;
    let mut target = OffscreenTarget::new(ctx, w, h, FRAMES_IN_FLIGHT).unwrap();
    let scene = build_scene(ctx, &cli.demo, FORMAT).unwrap();
    let mut r = Renderer::new(ctx, scene, cli.demo.shading, DrawPath::Compute).unwrap();
    for f in 0..frames {
        let begun = r.begin_frame(ctx).unwrap();
        assert!(r.draw(ctx, begun, &mut target, f as f32 * 0.5).unwrap());
    }
    r.finish(ctx).unwrap();
    let slots = FRAMES_IN_FLIGHT as u32;
    let pixels = (frames - 2..frames)
        .map(|f| target.read_rgba((f % slots) as usize).unwrap())
        .collect();
    (w, h, pixels)
}

/// Variance of the luma over a rectangle of columns [x0, x1).
fn variance(rgba: &[u8], w: u32, x0: u32, x1: u32) -> f64 {
    let mut v = Vec::new();
    for (i, p) in rgba.chunks_exact(4).enumerate() {
        let x = i as u32 % w;
        if (x0..x1).contains(&x) {
            v.push(0.299 * p[0] as f64 + 0.587 * p[1] as f64 + 0.114 * p[2] as f64);
        }
    }
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / v.len() as f64
}

fn changed_pixels(a: &[u8], b: &[u8]) -> usize {
    a.chunks_exact(4)
        .zip(b.chunks_exact(4))
        .filter(|(p, q)| p.iter().zip(q.iter()).any(|(x, y)| x.abs_diff(*y) > 8))
        .count()
}

#[test]
fn every_new_scene_renders_offscreen_not_blank_and_animated_scenes_change() {
    with_gpu(|ctx| {
        // A flat picture has variance 0; a shape on the background has hundreds (luma² units). 50 is well above
        // noise and well below any of the scenes (printed below).
        const MIN_VARIANCE: f64 = 50.0;
        for (scene, extra) in [
            ("voxels", &["--voxel-res", "32"][..]),
            ("curves", &[][..]),
            ("beziex", &[][..]),
        ] {
            let mut args = vec!["--scene", scene, "--size", "192x108", "--level", "4"];
            args.extend_from_slice(extra);
            let (w, _h, frames) = render(ctx, &args, 3);
            let v: Vec<f64> = frames.iter().map(|f| variance(f, w, 0, w)).collect();
            let changed = changed_pixels(&frames[0], &frames[1]);
            eprintln!("{scene}: luma variance {v:?}, {changed} pixels changed between frames");
            for x in &v {
                assert!(*x > MIN_VARIANCE, "{scene}: blank frame (variance {x})");
            }
            // Each scene moves (deformation, moving t / control point / weight, turntable): at least 0.5 % of
            // the pixels change by more than 8/255 in half a second.
            assert!(
                changed * 200 > frames[0].len() / 4,
                "{scene}: only {changed} pixels changed between frames"
            );
            if scene == "voxels" {
                // Both halves show something: the surface on the left, the ray-cast voxels on the right.
                let left = variance(&frames[1], w, 0, w / 2);
                let right = variance(&frames[1], w, w / 2, w);
                eprintln!("voxels: left variance {left:.0}, right variance {right:.0}");
                assert!(left > MIN_VARIANCE && right > MIN_VARIANCE);
            }
        }
    });
}

#[test]
fn bad_scene_input_gives_one_clear_message_and_a_failing_exit() {
    // The output folder's parent exists and is empty: a refused run must leave it empty (no frame, no
    // output folder, no temporary).
    let parent = std::env::temp_dir().join(format!(
        "gregvox_demo_scenes_bad_input_{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&parent);
    std::fs::create_dir_all(&parent).unwrap();
    let out = parent.join("frames");
    let out = out.to_str().unwrap();
    let missing = std::env::temp_dir().join("gregvox_no_such_model.gzjson");
    let cases: [(&[&str], &[&str]); 3] = [
        (
            &["--scene", "voxels", "--voxel-res", "1"],
            &["--voxel-res", "1"],
        ),
        (
            &["--scene", "voxels", "--voxel-scale", "0"],
            &["--voxel-scale", "0"],
        ),
        (
            &["--scene", "beziex", "--model", missing.to_str().unwrap()],
            &["gregvox_no_such_model.gzjson", "No such file"],
        ),
    ];
    for (args, needles) in cases {
        let mut argv = vec![
            "demo",
            "--offscreen",
            "--frames",
            "1",
            "--size",
            "32x32",
            "--out",
            out,
        ];
        argv.extend_from_slice(args);
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_gregvox"))
            .args(&argv)
            .output()
            .expect("the gregvox binary runs");
        common::assert_one_error_line(&format!("{args:?}"), &o, needles);
        assert_eq!(
            common::entries_under(&parent),
            Vec::<String>::new(),
            "{args:?} left something behind"
        );
    }
    let _ = std::fs::remove_dir_all(&parent);
}

#[test]
fn a_cage_past_the_uniform_refinement_limit_renders_in_the_cage_and_voxels_scenes() {
    // OpenSubdiv's catmark_car (RefineAdaptive(6): 136,419 patches; 6.45 M uniform, past the limit) is drawn
    // from its ptex layout: one grid per ptex face on the device, deformed every frame.
    let car = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/models/opensubdiv/catmark_car.obj"
    );
    with_gpu(|ctx| {
        for (scene, extra) in [
            ("cage", &["--deform", "twist"][..]),
            ("voxels", &["--voxel-res", "32", "--deform", "twist"][..]),
        ] {
            let mut args = vec![
                "--scene", scene, "--model", car, "--size", "192x108", "--level", "2",
            ];
            args.extend_from_slice(extra);
            let (w, _h, frames) = render(ctx, &args, 3);
            let v = variance(&frames[1], w, 0, w);
            let changed = changed_pixels(&frames[0], &frames[1]);
            eprintln!(
                "car in {scene}: luma variance {v:.0}, {changed} pixels changed between frames"
            );
            assert!(v > 50.0, "{scene}: blank frame (variance {v})");
            assert!(changed > 0, "{scene}: the deformed car did not move");
        }
        // The car's own UVs (`vt`), evaluated on the host at the ptex grid points, drive the checker.
        let base = [
            "--scene", "cage", "--model", car, "--size", "192x108", "--level", "2",
        ];
        let (_, _, phong) = render(ctx, &base, 2);
        let mut checker = base.to_vec();
        checker.extend_from_slice(&["--shading", "checker"]);
        let (_, _, checked) = render(ctx, &checker, 2);
        let differ = changed_pixels(&phong[1], &checked[1]);
        eprintln!("car with the checker of its UVs: {differ} pixels differ from Phong");
        assert!(differ > 200, "{differ}");
        // Screen-space adaptive tessellation carries the UVs too (the UV surface on each frame's grids).
        let bound = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/assets/models/opensubdiv/catmark_fvar_bound1.obj"
        );
        let base = [
            "--scene",
            "cage",
            "--model",
            bound,
            "--size",
            "192x108",
            "--adaptive",
            "8",
        ];
        let (_, _, phong) = render(ctx, &base, 2);
        let mut checker = base.to_vec();
        checker.extend_from_slice(&["--shading", "checker"]);
        let (_, _, checked) = render(ctx, &checker, 2);
        let differ = changed_pixels(&phong[1], &checked[1]);
        eprintln!(
            "adaptive grids with the checker of the cage's UVs: {differ} pixels differ from Phong"
        );
        assert!(differ > 200, "{differ}");
    });
}
