//! Specification of screen-space adaptive tessellation on the GPU (validation on, tests/common): per-patch
//! levels follow the level rule of `passes::adaptive_levels::patch_level`; shared edges take the smaller
//! level and both sides produce bit-identical position sets along them (crack-free); every vertex equals the
//! uniform evaluation at its level (interior: the patch's level; boundary: the edge's level, snapped); the
//! indirect draw commands address each patch's own grid; no NaN. Several views give strongly varying levels.
mod common;

use common::{model, with_gpu};
use glam::{DVec3, Mat4, Vec3};
use gregvox::engine::cage::cage_topology;
use gregvox::engine::gregory::GregorySurface;
use gregvox::gpu::Context;
use gregvox::mesh::load_obj;
use gregvox::passes::adaptive_levels::{draw_command, patch_level, AdaptiveParams, EdgeTopology};
use gregvox::passes::gregory_eval::SurfaceVertex;
use gregvox::surface::Tangents;
use std::collections::{BTreeSet, HashMap};

const L_MAX: u32 = 12;

/// Boundary rows of a patch grid at level `l`, in parameter order (the eval pass's edge numbering:
/// e0 v=0, e1 u=1, e2 v=1, e3 u=0), as local vertex indices j·(l+1)+i.
fn edge_row(e: usize, l: u32) -> Vec<usize> {
    let n = (l + 1) as usize;
    (0..n)
        .map(|k| match e {
            0 => k,
            1 => k * n + n - 1,
            2 => (n - 1) * n + k,
            _ => k * n,
        })
        .collect()
}

struct View {
    name: &'static str,
    params: AdaptiveParams,
}

/// Perspective views of spot: close-up and grazing views make near patches fine and far ones coarse; the last
/// puts the eye inside the model so that some control points lie behind it (those patches take L_max).
fn views(lo: Vec3, hi: Vec3) -> Vec<View> {
    let c = (lo + hi) * 0.5;
    let d = (hi - lo).length();
    let proj = Mat4::perspective_rh(45f32.to_radians(), 4.0 / 3.0, 0.01 * d, 10.0 * d);
    let at = |eye: Vec3, px: f32| AdaptiveParams {
        view_proj: proj * Mat4::look_at_rh(eye, c, Vec3::Y),
        viewport: [1024.0, 768.0],
        pixels_per_segment: px,
    };
    vec![
        View {
            name: "close front",
            params: at(c + Vec3::new(0.1, 0.05, 0.55) * d, 6.0),
        },
        View {
            name: "grazing side",
            params: at(c + Vec3::new(0.7, 0.02, 0.1) * d, 3.0),
        },
        View {
            name: "far",
            params: at(c + Vec3::new(-1.5, 0.8, -2.0) * d, 2.0),
        },
        View {
            name: "eye inside",
            params: at(c + Vec3::new(0.05, 0.0, 0.0) * d, 8.0),
        },
    ]
}

fn bits(v: &SurfaceVertex) -> [u32; 3] {
    [v.position[0], v.position[1], v.position[2]].map(f32::to_bits)
}

/// Uniform evaluation of the rest surface at `level` (one surface per level, cached).
fn uniform<'a>(
    ctx: &Context,
    cache: &'a mut HashMap<u32, Vec<SurfaceVertex>>,
    topo: &gregvox::engine::gregory::GregoryTopology,
    cage: &[DVec3],
    level: u32,
) -> &'a [SurfaceVertex] {
    cache.entry(level).or_insert_with(|| {
        let s = GregorySurface::new(ctx, topo, cage, level).unwrap();
        ctx.one_shot(|cmd| s.record(ctx, cmd, None, None)).unwrap();
        s.read_vertices(ctx).unwrap()
    })
}

#[test]
fn adaptive_levels_are_crack_free_and_equal_uniform_evaluation_at_their_levels() {
    let mesh = load_obj(model("spot_quadrangulated.obj")).unwrap();
    let (topo, cage, _) = cage_topology(&mesh, Tangents::OpenSubdiv).unwrap();
    let edges = EdgeTopology::new(&topo.patch_points);
    let patches = topo.patch_points.len();
    let (lo, hi) = cage.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(a, b), p| (a.min(p.as_vec3()), b.max(p.as_vec3())),
    );
    let slot = ((L_MAX + 1) * (L_MAX + 1)) as usize;
    with_gpu(|ctx| {
        let mut cache = HashMap::new();
        let mut s = GregorySurface::new(ctx, &topo, &cage, L_MAX).unwrap();
        for view in views(lo, hi) {
            s.set_adaptive(ctx, Some(view.params)).unwrap();
            ctx.one_shot(|cmd| s.record(ctx, cmd, None, None)).unwrap();
            let levels = s.read_levels(ctx).unwrap();
            let (edge_levels, edge_ids) = s.read_edge_levels(ctx).unwrap();
            let commands = s.read_draw_commands(ctx).unwrap();
            let vertices = s.read_vertices(ctx).unwrap();
            let points = s.read_points(ctx).unwrap();

            // 1. Levels vs the CPU rule (f64 from the same f32 control points). The GPU rounds in f32: where
            //    s / pixels_per_segment lies within 1e-4 (relative) of an integer, ⌈·⌉ may differ by one.
            let mut ambiguous = 0;
            for (p, rows) in topo.patch_points.iter().enumerate() {
                let cv: [DVec3; 20] = std::array::from_fn(|k| {
                    let q = points[rows[k] as usize];
                    DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64)
                });
                let (want, ratio) = patch_level(&cv, &view.params, L_MAX);
                if levels[p] != want {
                    let near = (ratio - ratio.round()).abs() <= 1e-4 * ratio.max(1.0);
                    assert!(
                        near && levels[p].abs_diff(want) == 1,
                        "{}: patch {p} level {} vs CPU {want} (ratio {ratio})",
                        view.name,
                        levels[p]
                    );
                    ambiguous += 1;
                }
            }
            let hist: BTreeSet<u32> = levels.iter().copied().collect();
            // 2. Edge levels = min over the patches sharing the edge; the edge ids are the host's.
            assert_eq!(edge_ids, edges.edge_ids, "{}", view.name);
            let mut coarser = 0;
            for (e, w) in edges.edge_offsets.windows(2).enumerate() {
                let share = &edges.edge_patches[w[0] as usize..w[1] as usize];
                let min = share.iter().map(|&p| levels[p as usize]).min().unwrap();
                assert_eq!(edge_levels[e], min, "{}: edge {e}", view.name);
                coarser += share.iter().filter(|&&p| levels[p as usize] > min).count();
            }
            // 3. One indexed-indirect command per patch, addressing its own grid in its slot.
            for (p, c) in commands.iter().enumerate() {
                assert_eq!(
                    *c,
                    draw_command(p as u32, levels[p], L_MAX),
                    "{}",
                    view.name
                );
            }
            // 4. Every drawn vertex: finite, and equal (bits) to the uniform evaluation at its level.
            let mut edge_sets: Vec<Vec<BTreeSet<[u32; 3]>>> =
                vec![Vec::new(); edges.edge_count() as usize];
            let mut drawn = 0usize;
            for p in 0..patches {
                let l = levels[p];
                let n = (l + 1) as usize;
                let grid = &vertices[p * slot..p * slot + n * n];
                drawn += n * n;
                assert!(grid.iter().all(|v| v
                    .position
                    .iter()
                    .chain(&v.normal)
                    .all(|c| c.is_finite())));
                let own = uniform(ctx, &mut cache, &topo, &cage, l);
                let own = &own[p * n * n..(p + 1) * n * n];
                for j in 1..n - 1 {
                    for i in 1..n - 1 {
                        assert_eq!(
                            grid[j * n + i],
                            own[j * n + i],
                            "{}: interior ({i},{j}) of patch {p} at level {l}",
                            view.name
                        );
                    }
                }
                for e in 0..4 {
                    let id = edge_ids[4 * p + e] as usize;
                    let le = edge_levels[id];
                    let coarse = uniform(ctx, &mut cache, &topo, &cage, le);
                    let m = (le + 1) as usize;
                    let coarse = &coarse[p * m * m..(p + 1) * m * m];
                    let coarse_row = edge_row(e, le);
                    for (k, &local) in edge_row(e, l).iter().enumerate() {
                        // Nearest coarse sample, ties up: the shader's snap.
                        let snapped = (2 * k as u32 * le + l) / (2 * l);
                        assert_eq!(
                            grid[local], coarse[coarse_row[snapped as usize]],
                            "{}: patch {p} edge {e} sample {k} (L_p {l}, L_e {le})",
                            view.name
                        );
                    }
                    edge_sets[id].push(edge_row(e, l).iter().map(|&v| bits(&grid[v])).collect());
                }
            }
            // 5. Crack-free: along every shared edge both sides give the same set of positions, bit for bit,
            //    exactly the L_e + 1 samples of the edge.
            let mut shared = 0;
            for (id, sets) in edge_sets.iter().enumerate() {
                assert_eq!(
                    sets[0].len() as u32,
                    edge_levels[id] + 1,
                    "{}: edge {id}",
                    view.name
                );
                for other in &sets[1..] {
                    assert_eq!(&sets[0], other, "{}: a crack along edge {id}", view.name);
                    shared += 1;
                }
            }
            eprintln!(
                "spot, {:12}: levels {:?}, {drawn} vertices drawn (uniform L_max: {}), {shared} shared edges, \
                 {coarser} patch edges snapped to a coarser neighbour, {ambiguous} levels at a rounding tie",
                view.name,
                hist,
                patches * slot
            );
            assert!(
                hist.len() >= 3,
                "{}: levels should vary strongly: {hist:?}",
                view.name
            );
            assert!(coarser > 0, "{}: no transition was exercised", view.name);
            assert!(
                ambiguous * 100 <= patches,
                "{}: {ambiguous} ties",
                view.name
            );
        }
    });
}

#[test]
fn bad_adaptive_parameters_are_clear_errors() {
    let mesh = load_obj(model("opensubdiv/catmark_cube.obj")).unwrap();
    let (topo, cage, _) = cage_topology(&mesh, Tangents::OpenSubdiv).unwrap();
    with_gpu(|ctx| {
        let mut s = GregorySurface::new(ctx, &topo, &cage, 4).unwrap();
        let good = AdaptiveParams {
            view_proj: Mat4::IDENTITY,
            viewport: [100.0, 100.0],
            pixels_per_segment: 4.0,
        };
        for (bad, needle) in [
            (
                AdaptiveParams {
                    pixels_per_segment: 0.0,
                    ..good
                },
                "pixels per segment",
            ),
            (
                AdaptiveParams {
                    viewport: [0.0, 10.0],
                    ..good
                },
                "viewport",
            ),
            (
                AdaptiveParams {
                    view_proj: Mat4::from_cols_array(&[f32::NAN; 16]),
                    ..good
                },
                "not finite",
            ),
        ] {
            let e = s.set_adaptive(ctx, Some(bad)).unwrap_err().to_string();
            assert!(e.contains(needle), "{e}");
        }
        assert!(s.read_levels(ctx).is_err(), "adaptive is still off");
        assert!(s.adaptive_draw().is_none());
    });
}

/// The level rule from its definition, written out here: project the 4 × 4 Bézier net's boundary control
/// polygons (row v = 0, column u = 1, row v = 1, column u = 0) through `view_proj` to pixels
/// ((ndc + 1) / 2 · viewport; the offset cancels in lengths), take the longest polygon length s, and
/// L = clamp(⌈s / pixels_per_segment⌉, 1, L_max), L_max when a control point is not in front of the eye.
/// Returns (L, s / pixels_per_segment).
fn level_by_definition(net: &[[DVec3; 4]; 4], p: &AdaptiveParams, l_max: u32) -> (u32, f64) {
    let m = p.view_proj.as_dmat4();
    let px = |q: DVec3| -> Option<glam::DVec2> {
        let c = m * q.extend(1.0);
        (c.w > 0.0).then(|| {
            glam::DVec2::new(
                c.x / c.w * p.viewport[0] as f64 / 2.0,
                c.y / c.w * p.viewport[1] as f64 / 2.0,
            )
        })
    };
    let polygons: [[DVec3; 4]; 4] = [
        net[0],
        std::array::from_fn(|j| net[j][3]),
        net[3],
        std::array::from_fn(|j| net[j][0]),
    ];
    let mut longest = 0.0f64;
    for poly in polygons {
        let mut len = 0.0;
        for w in poly.windows(2) {
            match (px(w[0]), px(w[1])) {
                (Some(a), Some(b)) => len += (b - a).length(),
                _ => return (l_max, f64::INFINITY),
            }
        }
        longest = longest.max(len);
    }
    let r = longest / p.pixels_per_segment as f64;
    ((r.ceil() as u32).clamp(1, l_max), r)
}

#[test]
fn hand_made_patches_get_the_level_of_their_projected_control_polygons_on_the_gpu_and_cpu() {
    use gregvox::geom::gregory::PatchF64;
    // Orthographic: 20 × 15 world units onto 1024 × 768 pixels, 51.2 px per unit in x and y.
    let ortho = Mat4::orthographic_rh(-10.0, 10.0, -7.5, 7.5, 0.1, 100.0)
        * Mat4::look_at_rh(Vec3::new(0.0, 0.0, 20.0), Vec3::ZERO, Vec3::Y);
    let persp = Mat4::perspective_rh(50f32.to_radians(), 4.0 / 3.0, 0.1, 100.0)
        * Mat4::look_at_rh(Vec3::new(0.0, 0.0, 6.0), Vec3::ZERO, Vec3::Y);
    let view = |m: Mat4, pps: f32| AdaptiveParams {
        view_proj: m,
        viewport: [1024.0, 768.0],
        pixels_per_segment: pps,
    };
    let square = |o: DVec3, side: f64, depth_slope: f64| -> [[DVec3; 4]; 4] {
        std::array::from_fn(|j| {
            std::array::from_fn(|i| {
                let (x, y) = (i as f64 / 3.0 * side, j as f64 / 3.0 * side);
                o + DVec3::new(x, y, depth_slope * y)
            })
        })
    };
    // Row v = 0 as a zig-zag: its control polygon (3 × √((1/3)² + ½²) ≈ 1.803 units = 92.3 px) is longer
    // than its curve's chord (1 unit), and the rule measures the polygon.
    let mut zigzag = square(DVec3::new(-4.0, -4.0, 0.0), 1.0, 0.0);
    zigzag[0][1].y += 0.5;
    zigzag[0][3].y += 0.5;
    // (name, Bézier net, view, the level the definition must give where it is known by hand)
    type Case = (&'static str, [[DVec3; 4]; 4], AdaptiveParams, Option<u32>);
    let cases: Vec<Case> = vec![
        // 1 unit = 51.2 px, 10 px per segment: 5.12 → 6.
        (
            "unit square",
            square(DVec3::ZERO, 1.0, 0.0),
            view(ortho, 10.0),
            Some(6),
        ),
        ("zig-zag row", zigzag, view(ortho, 10.0), Some(10)),
        (
            "tiny",
            square(DVec3::ZERO, 0.01, 0.0),
            view(ortho, 10.0),
            Some(1),
        ),
        (
            "huge",
            square(DVec3::new(-9.0, -7.0, 0.0), 14.0, 0.0),
            view(ortho, 2.0),
            Some(L_MAX),
        ),
        (
            "tilted in perspective",
            square(DVec3::new(-1.0, -1.0, 0.0), 2.0, -1.5),
            view(persp, 20.0),
            None,
        ),
        (
            "behind the eye",
            square(DVec3::new(0.0, 0.0, 5.0), 2.0, 1.0),
            view(persp, 20.0),
            Some(L_MAX),
        ),
    ];
    for (name, net, params, want) in &cases {
        let (level, ratio) = level_by_definition(net, params, L_MAX);
        if let Some(w) = want {
            assert_eq!(
                level, *w,
                "{name}: the definition gives {level} (ratio {ratio})"
            );
        }
        // Far from a rounding tie, so f32 on the GPU cannot round the other way.
        assert!(
            ratio.is_infinite() || (ratio - ratio.round()).abs() > 0.02 || ratio > L_MAX as f64,
            "{name}: ratio {ratio} too close to an integer for an exact test"
        );
        let cv = PatchF64::from_bezier(net).cv;
        assert_eq!(
            patch_level(&cv, params, L_MAX).0,
            level,
            "{name}: the CPU rule differs from the definition"
        );
        let gpu = with_gpu(|ctx| gpu_levels(ctx, &[cv], params));
        assert_eq!(
            gpu,
            vec![level],
            "{name}: the GPU level differs from the definition"
        );
    }
}

/// The adaptive-levels pass alone on isolated patches (20 points each): their levels.
fn gpu_levels(ctx: &Context, patches: &[[DVec3; 20]], params: &AdaptiveParams) -> Vec<u32> {
    use ash::vk;
    use gregvox::passes::adaptive_levels::{AdaptiveBuffers, AdaptiveLevelsPass};
    let pts: Vec<[f32; 4]> = patches
        .iter()
        .flat_map(|cv| cv.iter().map(|c| [c.x as f32, c.y as f32, c.z as f32, 1.0]))
        .collect();
    let rows: Vec<[u32; 20]> = (0..patches.len() as u32)
        .map(|p| std::array::from_fn(|k| 20 * p + k as u32))
        .collect();
    let edges = EdgeTopology::new(&rows);
    let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
    let up = |name: &str, bytes: &[u8]| ctx.upload_buffer(name, bytes, usage).unwrap();
    let out = |name: &str, bytes: u64, extra: vk::BufferUsageFlags| {
        ctx.create_buffer(
            name,
            bytes,
            usage | extra,
            gregvox::gpu::MemoryLocation::GpuOnly,
        )
        .unwrap()
    };
    let points = up("points", bytemuck::cast_slice(&pts));
    let patch_points = up("patch points", bytemuck::cast_slice(&rows));
    let edge_offsets = up("edge offsets", bytemuck::cast_slice(&edges.edge_offsets));
    let edge_patches = up("edge patches", bytemuck::cast_slice(&edges.edge_patches));
    let n = patches.len() as u64;
    let levels = out("levels", 4 * n, vk::BufferUsageFlags::empty());
    let commands = out("commands", 20 * n, vk::BufferUsageFlags::INDIRECT_BUFFER);
    let edge_levels = out(
        "edge levels",
        4 * edges.edge_count() as u64,
        vk::BufferUsageFlags::empty(),
    );
    let pass = AdaptiveLevelsPass::new(ctx).unwrap();
    let b = AdaptiveBuffers {
        points: &points,
        patch_points: &patch_points,
        levels: &levels,
        commands: &commands,
        edge_offsets: &edge_offsets,
        edge_patches: &edge_patches,
        edge_levels: &edge_levels,
    };
    ctx.one_shot(|cmd| pass.record(ctx, cmd, &b, params, (n as u32, edges.edge_count(), L_MAX)))
        .unwrap();
    ctx.read_pod::<u32>(&levels).unwrap()
}
