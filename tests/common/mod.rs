//! The GPU test harness: every GPU test runs inside [`with_gpu`], which builds a context with the validation
//! layer (and synchronization validation) required, and fails the test on any validation message or any
//! GPU allocation still alive at the end.
#![allow(dead_code)]
use gregvox::gpu::{Context, ContextDesc, Validation};

/// A context with validation required.
pub fn validated_context() -> Context {
    Context::with_desc(&ContextDesc {
        validation: Validation::Required,
        sync_validation: true,
        ..Default::default()
    })
    .expect("a Vulkan device with the validation layer (see README: apt packages)")
}

/// The library's GPU facade with validation required (call `finish` at the end to assert no leak and no
/// validation message).
pub fn validated_gpu() -> gregvox::api::Gpu {
    gregvox::api::Gpu::with_desc(&ContextDesc {
        validation: Validation::Required,
        sync_validation: true,
        ..Default::default()
    })
    .expect("a Vulkan device with the validation layer (see README: apt packages)")
}

/// Runs `f` with a validated context; then asserts no allocation is alive and no validation message came.
pub fn with_gpu<T>(f: impl FnOnce(&Context) -> T) -> T {
    let ctx = validated_context();
    let sink = ctx.validation.clone();
    let out = f(&ctx);
    // Everything the test dropped is destroyed once the device is idle; what is left was leaked.
    ctx.wait_idle().expect("vkDeviceWaitIdle");
    let live = ctx.live_allocations();
    drop(ctx);
    assert!(
        live.is_empty(),
        "GPU allocations still alive at the end of the test: {live:?}"
    );
    assert_eq!(
        sink.count(),
        0,
        "validation messages:\n{}",
        sink.messages().join("\n")
    );
    out
}

/// Path of a file in the repository's models folder (`assets/models`).
pub fn model(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets/models")
        .join(name)
}

/// Decodes the oracle fixtures' (value, run) byte pairs (tests/oracle/gen_voxel.py, gen_gwn.py).
pub fn unrle(b: &[u8]) -> Vec<u8> {
    assert_eq!(b.len() % 2, 0, "run-length data comes in pairs");
    let mut out = Vec::new();
    for p in b.chunks_exact(2) {
        out.extend(std::iter::repeat_n(p[0], p[1] as usize));
    }
    out
}

/// An oracle mask file (bool [i][j][k] of a res³ grid, C order, packed little-endian bits, run-length
/// coded) as a grid in `frame`, its popcount checked against `count`.
pub fn load_mask(
    file: &std::path::Path,
    frame: gregvox::voxel::grid::GridFrame,
    res: u32,
    count: u64,
) -> gregvox::voxel::grid::VoxelGrid {
    use gregvox::voxel::grid::{Axis, VoxelGrid};
    let bytes = unrle(&std::fs::read(file).unwrap());
    let r = res as usize;
    assert_eq!(bytes.len(), (r * r * r).div_ceil(8), "{}", file.display());
    let mut g = VoxelGrid::empty(frame, Axis::Z);
    for i in 0..r {
        for j in 0..r {
            for k in 0..r {
                let n = (i * r + j) * r + k;
                if bytes[n / 8] >> (n % 8) & 1 == 1 {
                    g.set(i as u32, j as u32, k as u32, true);
                }
            }
        }
    }
    assert_eq!(g.count(), count, "{}: popcount", file.display());
    g
}

/// Mask `kind` of oracle case `c` (an entry of a fixture folder's index.json) from `dir`, after checking
/// that the oracle sampled `frame` (origin and side as shortest round-trip text: serde_json's default float
/// parser is not correctly rounded, Rust's `str::parse` is).
pub fn oracle_mask(
    c: &serde_json::Value,
    dir: &std::path::Path,
    frame: gregvox::voxel::grid::GridFrame,
    res: u32,
    kind: &str,
) -> gregvox::voxel::grid::VoxelGrid {
    let exact = |v: &serde_json::Value| v.as_str().unwrap().parse::<f64>().unwrap();
    let origin: Vec<f64> = c["origin_text"]
        .as_array()
        .unwrap()
        .iter()
        .map(exact)
        .collect();
    assert_eq!(
        (origin.as_slice(), exact(&c["side_text"])),
        (frame.origin.as_slice(), frame.voxel_size[0] * res as f64),
        "{}: the oracle sampled another grid",
        c["model"]
    );
    let file = dir.join(c["files"][kind].as_str().unwrap());
    load_mask(&file, frame, res, c[kind].as_u64().unwrap())
}

/// The `inside` and `band` masks of oracle case `c` ([`oracle_mask`]).
pub fn oracle_masks(
    c: &serde_json::Value,
    dir: &std::path::Path,
    frame: gregvox::voxel::grid::GridFrame,
    res: u32,
) -> (
    gregvox::voxel::grid::VoxelGrid,
    gregvox::voxel::grid::VoxelGrid,
) {
    (
        oracle_mask(c, dir, frame, res, "inside"),
        oracle_mask(c, dir, frame, res, "band"),
    )
}

/// The entry of `model` at `res` in the index.json of oracle fixture folder `dir`.
pub fn oracle_case(dir: &std::path::Path, model: &str, res: u32) -> serde_json::Value {
    let file = dir.join("index.json");
    let index: serde_json::Value = serde_json::from_slice(
        &std::fs::read(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display())),
    )
    .unwrap();
    index["cases"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["model"] == model && c["res"] == res)
        .unwrap_or_else(|| panic!("no fixture for {model} at {res}"))
        .clone()
}

/// The CLI's failure contract (README "Errors and limits"): exit code 1, exactly one `gregvox: error:` line,
/// which contains every one of `needles` (the input and the problem), and no panic.
pub fn assert_one_error_line(what: &str, out: &std::process::Output, needles: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{what}: exit code\n{err}");
    assert!(!err.contains("panicked"), "{what}: panic:\n{err}");
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("gregvox: error:"))
        .collect();
    assert_eq!(lines.len(), 1, "{what}: one error line expected:\n{err}");
    for n in needles {
        assert!(
            lines[0].contains(n),
            "{what}: '{n}' not in the error line:\n{err}"
        );
    }
}

/// Every entry under `dir` (relative paths, sorted; folders with a trailing `/`); empty when `dir` does
/// not exist. Tests compare it before and after a failing command: nothing written, nothing left behind.
pub fn entries_under(dir: &std::path::Path) -> Vec<String> {
    fn walk(dir: &std::path::Path, base: &std::path::Path, out: &mut Vec<String>) {
        let Ok(rd) = std::fs::read_dir(dir) else {
            return;
        };
        for e in rd.flatten() {
            let p = e.path();
            let rel = p.strip_prefix(base).unwrap().display().to_string();
            if p.is_dir() {
                out.push(format!("{rel}/"));
                walk(&p, base, out);
            } else {
                out.push(rel);
            }
        }
    }
    let mut v = Vec::new();
    walk(dir, dir, &mut v);
    v.sort();
    v
}

/// The 20 control points of each Gregory patch as the GPU passes read them (f32 xyz, w = 1).
pub fn gregory_points(patches: &[gregvox::geom::gregory::PatchF64]) -> Vec<[f32; 4]> {
    patches
        .iter()
        .flat_map(|p| {
            p.cv.iter()
                .map(|c| [c.x as f32, c.y as f32, c.z as f32, 1.0])
        })
        .collect()
}

/// A deterministic pseudo-random Gregory patch: a bent bicubic net with independent face-point pairs.
pub fn random_patch(seed: u64) -> gregvox::geom::gregory::PatchF64 {
    let mut s = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut rnd = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let b: [[glam::DVec3; 4]; 4] = std::array::from_fn(|j| {
        std::array::from_fn(|i| {
            glam::DVec3::new(i as f64 + 0.2 * rnd(), j as f64 + 0.2 * rnd(), 0.6 * rnd())
        })
    });
    let mut g = gregvox::geom::gregory::PatchF64::from_bezier(&b);
    // Decouple the pairs: the interior points of a Gregory patch differ per edge.
    for k in [3, 4, 8, 9, 13, 14, 18, 19] {
        g.cv[k] += glam::DVec3::new(0.15 * rnd(), 0.15 * rnd(), 0.3 * rnd());
    }
    g
}

/// Checks (H, K) per grid vertex at `level` (patch-major, rows of u inner) against the CPU's fundamental
/// forms (`PatchF64::curvature`) of the same f32 control points evaluated in f64: where the CPU has a
/// curvature, within 1e-3 relative to max(1, |value|) — f32 second derivatives and a 2×2 determinant give a
/// few 1e-5 on the test cages (curvatures up to ~10 per unit), and a missing ∂²Q term changes H by O(1)
/// near the corners —, and (0, 0) where the CPU says singular. Returns (worst relative error, vertices
/// checked, singular vertices).
pub fn assert_curvature_matches_cpu(
    what: &str,
    patch_points: &[[u32; 20]],
    points: &[[f32; 4]],
    level: u32,
    hk: &[[f32; 2]],
) -> (f64, usize, usize) {
    use glam::DVec3;
    use gregvox::geom::gregory::PatchF64;
    let n1 = level as usize + 1;
    assert_eq!(
        hk.len(),
        patch_points.len() * n1 * n1,
        "{what}: vertex count"
    );
    let (mut worst, mut checked, mut singular) = (0.0f64, 0, 0);
    for (p, rows) in patch_points.iter().enumerate() {
        let cv = rows.map(|r| {
            let q = points[r as usize];
            DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64)
        });
        let patch = PatchF64 { cv };
        for j in 0..n1 {
            for i in 0..n1 {
                let (u, v) = (i as f64 / level as f64, j as f64 / level as f64);
                let [h, k] = hk[p * n1 * n1 + j * n1 + i];
                match patch.curvature(u, v) {
                    Some((kc, hc)) => {
                        let eh = (h as f64 - hc).abs() / hc.abs().max(1.0);
                        let ek = (k as f64 - kc).abs() / kc.abs().max(1.0);
                        worst = worst.max(eh).max(ek);
                        assert!(
                            eh < 1e-3 && ek < 1e-3,
                            "{what}, patch {p} ({u}, {v}): (H, K) = ({h}, {k}), CPU ({hc}, {kc})"
                        );
                        checked += 1;
                    }
                    None => {
                        assert_eq!(
                            [h, k],
                            [0.0, 0.0],
                            "{what}, patch {p} ({u}, {v}) is singular"
                        );
                        singular += 1;
                    }
                }
            }
        }
    }
    assert!(checked > 0, "{what}: nothing to check");
    (worst, checked, singular)
}

/// The angle between two vectors in radians, accurate for nearly parallel ones: glam's `angle_between`
/// takes the acos of the dot product, which reads one f32 ulp below 1 as 4.9e-4 rad.
pub fn angle(a: glam::Vec3, b: glam::Vec3) -> f32 {
    a.cross(b).length().atan2(a.dot(b))
}

/// What a device's rasterizer may do differently from the CPU scanline: Vulkan leaves the rounding of
/// vertices to sub-pixel positions to the implementation, so a centre within the snapping distance of a
/// triangle (2^-9 of a voxel per axis at 8 sub-pixel bits) may be covered on one and not the other. This is
/// that band with a margin of two: 1/256 of the largest voxel edge (the H200's differences lay within
/// 1.2e-3 voxel edges of a triangle).
pub const SNAP_BAND_VOXELS: f64 = 1.0 / 256.0;

/// Checks a grid made by a device method against the CPU scanline's grid of the same triangles: different
/// only at voxels whose centre lies within [`SNAP_BAND_VOXELS`] of a triangle of `triangles` (positions in
/// the grid's frame). Lavapipe snaps as the scanline does and differs in a voxel or none; an NVIDIA H200
/// differed in 4–16 voxels per model, every one in the band. Returns the number of voxels that differ.
pub fn assert_same_up_to_snapping(
    device: &gregvox::voxel::grid::VoxelGrid,
    cpu: &gregvox::voxel::grid::VoxelGrid,
    triangles: &gregvox::voxel::mesh::TriMesh,
    what: &str,
) -> u64 {
    use gregvox::voxel::gwn::kernel::triangle_distance;
    assert_eq!(device.frame.dims, cpu.frame.dims, "{what}: dims");
    let diff = device.count_differences(cpu);
    if diff == 0 {
        return 0;
    }
    let (name, kind) = gregvox::gpu::context::probe_device().expect("a Vulkan device");
    let f = device.frame;
    let h = f.voxel_size.iter().fold(0.0f64, |m, &x| m.max(x));
    let band = h * SNAP_BAND_VOXELS;
    let tris: Vec<[[f64; 3]; 3]> = triangles
        .triangles
        .iter()
        .map(|t| t.map(|v| triangles.positions[v as usize].map(|x| x as f64)))
        .collect();
    let mut worst = 0.0f64;
    for i in 0..f.dims[0] {
        for j in 0..f.dims[1] {
            for k in 0..f.dims[2] {
                if device.get(i, j, k) == cpu.get(i, j, k) {
                    continue;
                }
                let c = f.centre(i, j, k);
                let d = tris
                    .iter()
                    .map(|t| triangle_distance(c, t[0], t[1], t[2]))
                    .fold(f64::INFINITY, f64::min);
                worst = worst.max(d);
                assert!(
                    d <= band,
                    "{what}: voxel ({i}, {j}, {k}) differs on {name} ({kind}) {:.4} voxel edges from the \
                     surface, beyond the snapping band of {SNAP_BAND_VOXELS} ({diff} differ)",
                    d / h
                );
            }
        }
    }
    eprintln!(
        "{what}: {diff} voxels differ on {name}, all within {:.2e} voxel edges of a triangle",
        worst / h
    );
    diff
}

/// The colour format [`render_frame`]'s target has (the demo's offscreen format).
pub const FRAME_FORMAT: ash::vk::Format = ash::vk::Format::B8G8R8A8_UNORM;

/// Renders one frame through an offscreen target of `w`×`h` ([`FRAME_FORMAT`]) and a D32 depth image, both
/// in attachment layouts when `draw` records into them (contents undefined: `draw` clears), and returns the
/// frame as RGBA8 rows, top to bottom.
pub fn render_frame(
    ctx: &Context,
    w: u32,
    h: u32,
    draw: impl FnOnce(ash::vk::CommandBuffer, &gregvox::passes::draw::DrawTarget) -> gregvox::Result<()>,
) -> Vec<u8> {
    use ash::vk;
    use gregvox::gpu::PresentTarget;
    let mut target = gregvox::gpu::OffscreenTarget::new(ctx, w, h, 1).unwrap();
    let depth = ctx
        .create_image(
            "test frame depth",
            &gregvox::gpu::ImageDesc::d2(
                w,
                h,
                vk::Format::D32_SFLOAT,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            ),
        )
        .unwrap();
    let img = target.acquire(ctx, 0).unwrap().expect("an offscreen image");
    ctx.one_shot(|cmd| {
        gregvox::gpu::present::begin_color_target(ctx, cmd, img.image);
        gregvox::gpu::resources::image_barrier(
            ctx,
            cmd,
            depth.raw(),
            depth.range(),
            vk::ImageLayout::UNDEFINED,
            vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
            (
                vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS,
                vk::AccessFlags2::NONE,
            ),
            (
                vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS
                    | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS,
                vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ
                    | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE,
            ),
        );
        draw(
            cmd,
            &gregvox::passes::draw::DrawTarget {
                color: img.view,
                depth: depth.view(),
                extent: img.extent,
                resolve: None,
            },
        )?;
        target.record_finish(ctx, cmd, &img);
        Ok(())
    })
    .unwrap();
    target.present(ctx, &img).unwrap();
    target.read_rgba(0).unwrap()
}

/// Runs `gregvox demo` in a window under Xvfb (`xvfb-run`, from `scripts/setup.sh`) with the validation
/// layer on, `args` and the scripted `--keys` entries, writing into `out`; asserts it succeeded with no
/// validation message and no panic, and returns its standard error (the demo's log).
pub fn run_demo_window(args: &[&str], keys: &[String], out: &std::path::Path) -> String {
    let output = std::process::Command::new("xvfb-run")
        .args(["-a", env!("CARGO_BIN_EXE_gregvox"), "demo"])
        .args(args)
        .args(["--keys", &keys.join(",")])
        .arg("--out")
        .arg(out)
        .env("GREGVOX_VALIDATION", "1")
        .output()
        .expect("xvfb-run (apt-get install xvfb xauth; scripts/setup.sh installs it)");
    let err = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "{err}");
    assert!(
        !err.contains("vulkan validation"),
        "validation messages:\n{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    err
}

/// Largest normal jump (rad) across the shared edges of a `columns × rows` flag, 33 samples per edge.
pub fn flag_max_jump(p: &[gregvox::geom::gregory::PatchF64], columns: usize, rows: usize) -> f64 {
    let mut worst = 0.0f64;
    for r in 0..rows {
        for c in 0..columns {
            let a = &p[r * columns + c];
            for k in 0..=32 {
                let t = k as f64 / 32.0;
                if c + 1 < columns {
                    let b = &p[r * columns + c + 1];
                    let (ua, va) = gregvox::geom::compat::Edge::U1.uv(t);
                    let (ub, vb) = gregvox::geom::compat::Edge::U0.uv(t);
                    assert!((a.eval(ua, va).0 - b.eval(ub, vb).0).length() < 1e-12);
                    worst = worst.max({
                        let (m, n) = (a.normal(ua, va), b.normal(ub, vb));
                        m.cross(n).length().atan2(m.dot(n))
                    });
                }
                if r + 1 < rows {
                    let b = &p[(r + 1) * columns + c];
                    let (ua, va) = gregvox::geom::compat::Edge::V1.uv(t);
                    let (ub, vb) = gregvox::geom::compat::Edge::V0.uv(t);
                    worst = worst.max({
                        let (m, n) = (a.normal(ua, va), b.normal(ub, vb));
                        m.cross(n).length().atan2(m.dot(n))
                    });
                }
            }
        }
    }
    worst
}

/// Fraction of pixels whose channels differ by more than `slack`.
pub fn differing(a: &[u8], b: &[u8], slack: u8) -> f64 {
    let n = a.len() / 4;
    let count = a
        .chunks_exact(4)
        .zip(b.chunks_exact(4))
        .filter(|(p, q)| p.iter().zip(q.iter()).any(|(x, y)| x.abs_diff(*y) > slack))
        .count();
    count as f64 / n as f64
}

/// Width, height and RGBA8 pixels of a PNG gregvox wrote.
pub fn read_png(path: &std::path::Path) -> (u32, u32, Vec<u8>) {
    let file = std::fs::File::open(path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (golden frames: generate them with BLESS=1)",
            path.display()
        )
    });
    let mut reader = png::Decoder::new(file).read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgba, "{}", path.display());
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

/// `n` points uniform in the box of the vertices the faces use, padded by 10 % per side, then `n` near the
/// surface: a random triangle, a uniform point of it, moved per axis by (u₁ + u₂ + u₃ − 1.5)·1 % of the box.
/// The same float64 operations in the same order as `tests/oracle/gen_query.py`, so the same bits
/// (`tests/query_points.rs`).
pub fn dataset_points(t: &gregvox::voxel::mesh::TriMesh, n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for &v in t.triangles.iter().flatten() {
        let p = t.positions[v as usize];
        for a in 0..3 {
            lo[a] = lo[a].min(p[a] as f64);
            hi[a] = hi[a].max(p[a] as f64);
        }
    }
    let size: [f64; 3] = std::array::from_fn(|a| hi[a] - lo[a]);
    let mut rng = gregvox::voxel::stress::SplitMix64(seed);
    let mut out = Vec::with_capacity(2 * n);
    for _ in 0..n {
        let u = [rng.unit(), rng.unit(), rng.unit()];
        out.push(std::array::from_fn(|a| {
            (lo[a] - 0.1 * size[a]) + (1.2 * size[a]) * u[a]
        }));
    }
    for _ in 0..n {
        let tri = t.triangles[rng.below(t.triangles.len())];
        let (u, v) = (rng.unit(), rng.unit());
        let (u, v) = if u + v > 1.0 {
            (1.0 - u, 1.0 - v)
        } else {
            (u, v)
        };
        let c = |k: usize, a: usize| t.positions[tri[k] as usize][a] as f64;
        let mut p = [0.0; 3];
        for (a, pa) in p.iter_mut().enumerate() {
            let s = (rng.unit() + rng.unit() + rng.unit() - 1.5) * 0.01 * size[a];
            *pa = c(0, a) + u * (c(1, a) - c(0, a)) + v * (c(2, a) - c(0, a)) + s;
        }
        out.push(p);
    }
    out
}
