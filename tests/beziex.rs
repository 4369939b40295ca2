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

/// What [`max_shared_edge_jump`] found.
struct SharedEdges {
    pairs: usize,
    /// Largest angle (rad, 0 to π) between the normals on either side of a shared edge.
    worst: f64,
    /// Shared edges whose two patches run it the same way round (inconsistent orientation).
    inconsistent: usize,
    /// Samples where a side has no tangent plane: the cross-boundary derivative vanishes, so the normal is
    /// undefined there (04_Cup1's rim: |S_cross| ≈ 5e-8 against |S_along| ≈ 0.7).
    undefined: usize,
}

/// Whether S_u and S_v span a plane: neither is below 1e-6 of the other, nor are they parallel.
fn has_tangent_plane(p: &BeziexPatch, u: f64, v: f64) -> bool {
    let (_, su, sv) = p.eval(u, v);
    let (a, b) = (su.length(), sv.length());
    a.min(b) > 1e-6 * a.max(b) && su.cross(sv).length() > 1e-6 * a * b
}

/// The angle between two unit vectors, accurate near 0 and π (acos is not: √ε ≈ 1e-8 rad).
fn angle(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// Normal jumps over edges shared by two patches, matched by their elevated boundary curves, 33 samples
/// each; `flip` negates one patch's normals (the negative control). The angle is the full angle between
/// the normals: a flipped normal shows as π. Patches of one orientation run a shared edge opposite ways,
/// counter-clockwise in each frame; an edge run the same way round by both is counted as inconsistent.
fn max_shared_edge_jump(patches: &[BeziexPatch], flip: Option<usize>) -> SharedEdges {
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
    // +1 where the counter-clockwise boundary runs along the curve's parameter (e0 v=0, e1 u=1), −1 where
    // against it (e2 v=1, e3 u=0).
    let ccw = |e: usize| if e < 2 { 1 } else { -1 };
    let same = |a: &[DVec3; 7], b: &[DVec3; 7], rev: bool| {
        (0..7).all(|k| (a[k] - b[if rev { 6 - k } else { k }]).length() < 1e-6 * d)
    };
    let normal = |p: usize, u: f64, v: f64| {
        let n = patches[p].normal(u, v);
        if flip == Some(p) {
            -n
        } else {
            n
        }
    };
    let mut r = SharedEdges {
        pairs: 0,
        worst: 0.0,
        inconsistent: 0,
        undefined: 0,
    };
    for a in 0..patches.len() {
        for ea in 0..4 {
            let ca = curve(&patches[a], ea);
            for b in a + 1..patches.len() {
                for eb in 0..4 {
                    let cb = curve(&patches[b], eb);
                    for rev in [false, true] {
                        if !same(&ca, &cb, rev) {
                            continue;
                        }
                        r.pairs += 1;
                        if ccw(ea) * ccw(eb) * if rev { -1 } else { 1 } != -1 {
                            r.inconsistent += 1;
                        }
                        for k in 0..=32 {
                            let t = k as f64 / 32.0;
                            let (ua, va) = uv(ea, t);
                            let (ub, vb) = uv(eb, if rev { 1.0 - t } else { t });
                            if !has_tangent_plane(&patches[a], ua, va)
                                || !has_tangent_plane(&patches[b], ub, vb)
                            {
                                r.undefined += 1;
                                continue;
                            }
                            r.worst = r.worst.max(angle(normal(a, ua, va), normal(b, ub, vb)));
                        }
                    }
                }
            }
        }
    }
    r
}

#[test]
fn shared_edges_of_the_sphere_and_the_cup_are_g1() {
    // (file, shared edges at least, samples without a tangent plane: on the cup, the 8 rim edges and the
    // rim end of the 16 edges that meet them)
    for (name, min_pairs, undefined) in [
        ("19_Sphere1.gzjson", 48, 0),
        ("04_Cup1.gzjson", 40, 8 * 33 + 16),
    ] {
        let patches = load(name);
        let r = max_shared_edge_jump(&patches, None);
        eprintln!(
            "{name}: {} shared edges matched, {} samples without a tangent plane, max normal jump {:.2e} rad",
            r.pairs, r.undefined, r.worst
        );
        assert!(
            r.pairs >= min_pairs,
            "{name}: only {} shared edges found",
            r.pairs
        );
        assert_eq!(r.inconsistent, 0, "{name}: inconsistently oriented patches");
        assert_eq!(
            r.undefined, undefined,
            "{name}: samples without a tangent plane"
        );
        assert!(r.worst <= 1e-3, "{name}: {}", r.worst);
        // Negative control: a patch with its normals flipped fails.
        let flipped = max_shared_edge_jump(&patches, Some(patches.len() / 3));
        assert!(
            flipped.worst > 3.0,
            "{name}: a flipped patch passed ({})",
            flipped.worst
        );
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
                resolve: None,
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

/// Evaluates Gregory patches (20 rows each in `idx` into `pts`) with the compute pass.
fn gregory_compute(
    pts: &[[f32; 4]],
    idx: &[u32],
    patch_count: u32,
    level: u32,
) -> Vec<SurfaceVertex> {
    with_gpu(|ctx| {
        let pass = GregoryEvalPass::new(ctx).unwrap();
        let pb = storage(ctx, "points", bytemuck::cast_slice(pts));
        let ib = storage(ctx, "patch points", bytemuck::cast_slice(idx));
        let fb = storage(
            ctx,
            "flags",
            bytemuck::cast_slice(&vec![0u32; patch_count as usize]),
        );
        let out = output(ctx, "vertices", vertex_count(patch_count, level) * 32);
        ctx.one_shot(|cmd| {
            pass.record(
                ctx,
                cmd,
                gregvox::passes::gregory_eval::ControlPoints::plain(&pb),
                &ib,
                &fb,
                patch_count,
                level,
                false,
                &out,
            )
        })
        .unwrap();
        ctx.read_pod::<SurfaceVertex>(&out).unwrap()
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
    let pts = common::gregory_points(&patches);
    let idx: Vec<u32> = (0..pts.len() as u32).collect();
    let pulled = vertex_pull(PatchKind::Gregory, &pts, &idx, patches.len() as u32, level);
    let computed = gregory_compute(&pts, &idx, patches.len() as u32, level);
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

// ---------------------------------------------------------------------------------------------------------
// Known answers, independent of the evaluators: patches whose surface the format's description gives in
// closed form, evaluated here by de Casteljau (no Bernstein table, no elevation code of the crate).

/// A cubic Bézier and its derivative at t, by de Casteljau.
fn de_casteljau3(p: [DVec3; 4], t: f64) -> (DVec3, DVec3) {
    let l = |a: DVec3, b: DVec3| a + (b - a) * t;
    let (a, b, c) = (l(p[0], p[1]), l(p[1], p[2]), l(p[2], p[3]));
    let (d, e) = (l(a, b), l(b, c));
    (l(d, e), (e - d) * 3.0)
}

/// A bicubic Bézier net `net[j][i]` (i along u, j along v): (S, S_u, S_v).
fn bicubic(net: &[[DVec3; 4]; 4], u: f64, v: f64) -> (DVec3, DVec3, DVec3) {
    let rows: [(DVec3, DVec3); 4] = std::array::from_fn(|j| de_casteljau3(net[j], u));
    let (s, sv) = de_casteljau3(rows.map(|r| r.0), v);
    let (su, _) = de_casteljau3(rows.map(|r| r.1), v);
    (s, su, sv)
}

/// A cubic's control points raised to degree 6 by the closed form
/// Q_k = Σ_i C(3, i)·C(3, k − i) / C(6, k) · P_i.
fn raise_to_sextic(p: [DVec3; 4]) -> [DVec3; 7] {
    let c = |n: usize, k: usize| -> f64 {
        (0..k).fold(1.0, |a, i| a * (n - i) as f64 / (i + 1) as f64)
    };
    std::array::from_fn(|k| {
        (k.saturating_sub(3)..=k.min(3))
            .map(|i| p[i] * (c(3, i) * c(3, k - i) / c(6, k)))
            .sum()
    })
}

/// The Beziex patch whose horizontal net Ra is the Bézier net `a` and vertical net Rb is `b` (the format:
/// Ra rows j = 0..3 of 7 points in u, Rb columns i = 0..3 of 7 points in v, each a degree-6 row).
fn beziex_of(a: &[[DVec3; 4]; 4], b: &[[DVec3; 4]; 4]) -> BeziexPatch {
    BeziexPatch {
        ra: std::array::from_fn(|j| raise_to_sextic(a[j])),
        rb: std::array::from_fn(|i| raise_to_sextic(std::array::from_fn(|j| b[j][i]))),
        pre_divided: false,
    }
}

/// The format's surface (Beziex_We's shader: `getPosMixMain`): S = (pu·Ra + pv·Rb) / (pu + pv), pu = u(1−u),
/// pv = v(1−v), with Ra itself at the four corners; its normal is normalize(S_u × S_v), the derivatives
/// taken of that quotient. Here Ra and Rb are the Bézier nets `a` and `b` evaluated by de Casteljau.
fn beziex_known(a: &[[DVec3; 4]; 4], b: &[[DVec3; 4]; 4], u: f64, v: f64) -> (DVec3, DVec3) {
    let (ra, ra_u, ra_v) = bicubic(a, u, v);
    let (rb, rb_u, rb_v) = bicubic(b, u, v);
    let (pu, pv) = (u * (1.0 - u), v * (1.0 - v));
    if pu + pv == 0.0 {
        return (ra, ra_u.cross(ra_v).normalize());
    }
    let (w, dpu, dpv) = (pu + pv, 1.0 - 2.0 * u, 1.0 - 2.0 * v);
    let num = ra * pu + rb * pv;
    let su = ((ra * dpu + ra_u * pu + rb_u * pv) * w - num * dpu) / (w * w);
    let sv = ((ra_v * pu + rb * dpv + rb_v * pv) * w - num * dpv) / (w * w);
    (num / w, su.cross(sv).normalize())
}

/// Three hand-made cases: a flat patch (an affine image of the unit square: S = o + u·e1 + v·e2, normal
/// e1 × e2), a Bézier patch in disguise (Ra = Rb = one bicubic net: S is that bicubic), and a true blend
/// (Ra and Rb two nets sharing their boundary rows: S = the blend above, at the centre (Ra + Rb) / 2).
/// A 4 × 4 Bézier net, `net[j][i]` (i along u, j along v).
type Net = [[DVec3; 4]; 4];

fn hand_made_nets() -> Vec<(&'static str, Net, Net)> {
    let (o, e1, e2) = (
        DVec3::new(0.5, -1.0, 2.0),
        DVec3::new(2.0, 0.5, 0.25),
        DVec3::new(-0.5, 1.5, 1.0),
    );
    let flat: [[DVec3; 4]; 4] = std::array::from_fn(|j| {
        std::array::from_fn(|i| o + e1 * (i as f64 / 3.0) + e2 * (j as f64 / 3.0))
    });
    // A deterministic, far-from-flat net.
    let bumpy: [[DVec3; 4]; 4] = std::array::from_fn(|j| {
        std::array::from_fn(|i| {
            let (x, y) = (i as f64, j as f64);
            DVec3::new(
                x + 0.2 * y,
                y - 0.1 * x * y,
                0.6 * ((x * 1.3 + y * 0.7).sin()),
            )
        })
    });
    let mut other = bumpy;
    for (j, i) in [(1, 1), (1, 2), (2, 1), (2, 2)] {
        other[j][i] += DVec3::new(0.15 * i as f64, -0.2, 0.5 * j as f64 - 0.4);
    }
    vec![
        ("flat", flat, flat),
        ("bezier in disguise", bumpy, bumpy),
        ("blend", bumpy, other),
    ]
}

/// Largest position distance and normal angle of patch `k`'s grid vertices at `level`, in each of
/// `grids`, from the `known` surface point and unit normal at (u, v).
fn worst_vs_known(
    grids: &[&[SurfaceVertex]],
    k: usize,
    level: u32,
    known: impl Fn(f64, f64) -> (DVec3, DVec3),
) -> (f64, f64) {
    let n = (level + 1) as usize;
    let (mut dp, mut dn) = (0.0f64, 0.0f64);
    for j in 0..n {
        for i in 0..n {
            let (s, nrm) = known(i as f64 / level as f64, j as f64 / level as f64);
            for g in grids {
                let g = &g[k * n * n + j * n + i];
                let gp = DVec3::new(
                    g.position[0] as f64,
                    g.position[1] as f64,
                    g.position[2] as f64,
                );
                let gn = DVec3::new(g.normal[0] as f64, g.normal[1] as f64, g.normal[2] as f64);
                dp = dp.max((gp - s).length());
                dn = dn.max(angle(gn.normalize(), nrm));
            }
        }
    }
    (dp, dn)
}

#[test]
fn hand_made_patches_evaluate_to_their_known_surfaces_on_the_cpu_the_compute_pass_and_vertex_pull()
{
    let level = 8;
    let n = (level + 1) as usize;
    let nets = hand_made_nets();
    let patches: Vec<BeziexPatch> = nets.iter().map(|(_, a, b)| beziex_of(a, b)).collect();
    let computed = gpu_compute(&patches, level);
    let flat: Vec<[f32; 4]> = patches.iter().flat_map(|p| p.to_gpu()).collect();
    let pulled = vertex_pull(PatchKind::Beziex, &flat, &[0], patches.len() as u32, level);
    for (k, (name, a, b)) in nets.iter().enumerate() {
        let (mut cpu_p, mut cpu_n) = (0.0f64, 0.0f64);
        for j in 0..n {
            for i in 0..n {
                let (u, v) = (i as f64 / level as f64, j as f64 / level as f64);
                let (s, nrm) = beziex_known(a, b, u, v);
                cpu_p = cpu_p.max((patches[k].eval(u, v).0 - s).length());
                cpu_n = cpu_n.max(angle(patches[k].normal(u, v), nrm));
            }
        }
        let (gpu_p, gpu_n) = worst_vs_known(&[&computed, &pulled], k, level, |u, v| {
            beziex_known(a, b, u, v)
        });
        eprintln!(
            "{name}: CPU |ΔS| {cpu_p:.1e}, normal {cpu_n:.1e} rad; compute and vertex pull |ΔS| {gpu_p:.1e}, normal {gpu_n:.1e} rad"
        );
        assert!(
            cpu_p <= 1e-12 && cpu_n <= 1e-9,
            "{name}: CPU {cpu_p:e} {cpu_n:e}"
        );
        assert!(
            gpu_p <= 2e-6 && gpu_n <= 1e-4,
            "{name}: GPU {gpu_p:e} {gpu_n:e}"
        );
    }
    // The cases are what they claim: the flat patch is the plane, the blend's centre the mean of its nets.
    let (_, a, b) = &nets[0];
    let (s, nrm) = beziex_known(a, b, 0.3, 0.6);
    let want = DVec3::new(0.5, -1.0, 2.0)
        + DVec3::new(2.0, 0.5, 0.25) * 0.3
        + DVec3::new(-0.5, 1.5, 1.0) * 0.6;
    assert!((s - want).length() < 1e-14);
    let plane = DVec3::new(2.0, 0.5, 0.25)
        .cross(DVec3::new(-0.5, 1.5, 1.0))
        .normalize();
    assert!(angle(nrm, plane) < 1e-12);
    let (_, a, b) = &nets[2];
    let centre = (bicubic(a, 0.5, 0.5).0 + bicubic(b, 0.5, 0.5).0) * 0.5;
    assert!((patches[2].eval(0.5, 0.5).0 - centre).length() < 1e-12);
    assert!(
        (bicubic(a, 0.5, 0.5).0 - bicubic(b, 0.5, 0.5).0).length() > 0.1,
        "a real blend"
    );
}

#[test]
fn hand_made_gregory_patches_are_their_bezier_patches_in_compute_and_vertex_pull() {
    // A Gregory patch whose face-point pairs coincide is the bicubic Bézier patch of its net: the closed
    // form the two GPU paths (which share their shader includes) are checked against, not each other.
    let level = 8;
    let nets: Vec<[[DVec3; 4]; 4]> = hand_made_nets().into_iter().map(|(_, a, _)| a).collect();
    let patches: Vec<PatchF64> = nets.iter().map(PatchF64::from_bezier).collect();
    let pts = common::gregory_points(&patches);
    let idx: Vec<u32> = (0..pts.len() as u32).collect();
    let pulled = vertex_pull(PatchKind::Gregory, &pts, &idx, patches.len() as u32, level);
    let computed = gregory_compute(&pts, &idx, patches.len() as u32, level);
    for (k, net) in nets.iter().enumerate() {
        let (dp, dn) = worst_vs_known(&[&computed, &pulled], k, level, |u, v| {
            let (s, su, sv) = bicubic(net, u, v);
            (s, su.cross(sv).normalize())
        });
        eprintln!("gregory net {k}: compute and vertex pull vs de Casteljau |ΔS| {dp:.1e}, normal {dn:.1e} rad");
        assert!(dp <= 2e-6 && dn <= 1e-4, "net {k}: {dp:e} {dn:e}");
    }
}
