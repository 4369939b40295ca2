//! Suite `thesis`: Takeda 2008's Tables 3.1–3.3 on this machine.
//!
//! - 3.1: the 3 × 2 flag (the thesis's 2 × 3 patches, 10 × 10 grid per patch) built and evaluated per frame
//!   with and without the Chiyokura–Kimura correction: GPU ms/frame from timestamps, wall ms/frame (record +
//!   submit + wait) and the f64 CPU reference's ms/frame.
//! - 3.2: a 3 × 3 quad cage at 6², 12², 24², 48², 96² faces: Catmull–Clark in matrix form (k levels, k = 1…5;
//!   CPU: one SpMV per level; GPU: the composed S = S_k⋯S_1 in one SpMV pass) vs Gregory evaluation at level
//!   n/3 per patch (the same face count; CPU: W·cage + f64 tessellation; GPU: SpMV + evaluation pass).
//!   The thesis timed 10 generations and reported the mean; we report the median of the repeats.
//! - 3.3: the six-patch plane (3 × 2 quads), deformed (the `wave` map of glsl/cage_deform.comp) and
//!   regenerated at level 32: CPU only (the map ported to f64 Rust + W·cage + tessellation) vs GPU (deform +
//!   SpMV + evaluation, timestamps and wall).
//!
//! Invariants: topology (subdivision matrices, Gregory stencils) is built once before timing, as an animated
//! cage would; what is timed is the per-frame work. Every GPU object is dropped (released through the
//! release queue) before returning.
use super::{num, time_cpu, time_gpu, BenchConfig, Report, Table};
use crate::engine::flag::{flag_patches, FlagParams, FlagSurface};
use crate::engine::gregory::GregorySurface;
use crate::gpu::{Context, MemoryLocation};
use crate::mesh::{Mesh, MeshMatrix, SparseMatrix, SubdivisionStack};
use crate::passes::cage_deform::{DeformParams, Deformation};
use crate::passes::spmv::{GpuSparse, SpmvPass};
use crate::surface::{tessellate, GregoryStencils, Tangents};
use ash::vk;
use glam::DVec3;

/// An `nx × ny` quad grid on [0, nx] × [0, ny] with a smooth bump in z (so the surfaces are not planar).
pub fn grid_cage(nx: u32, ny: u32) -> Mesh {
    let mut positions = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            let (x, y) = (i as f64, j as f64);
            let z = 0.3 * (1.3 * x).sin() * (0.9 * y + 0.4).cos();
            positions.push(DVec3::new(x, y, z));
        }
    }
    let id = |i: u32, j: u32| j * (nx + 1) + i;
    let faces: Vec<Vec<u32>> = (0..ny)
        .flat_map(|j| {
            (0..nx).map(move |i| vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)])
        })
        .collect();
    Mesh::from_polygons(positions, &faces).expect("a valid quad grid")
}

/// The `wave` deformation of glsl/cage_deform.comp in f64 (mode 3; `t`, `amplitude` as in `DeformParams`).
pub fn wave_cpu(rest: &[DVec3], t: f64, amplitude: f64) -> Vec<DVec3> {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in rest {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let size = hi - lo;
    let s = size.max_element();
    let tau = std::f64::consts::TAU;
    rest.iter()
        .map(|&p| {
            let q = (p - lo) / size.max(DVec3::splat(1e-20));
            let mut o = p;
            o.z += amplitude * 0.08 * s * (tau * (q.x * 1.5 - 0.25 * t)).sin();
            o.y += amplitude * 0.04 * s * (tau * (q.z - 0.3 * t)).sin();
            o
        })
        .collect()
}

/// Runs the three tables.
pub fn run(ctx: &Context, cfg: &BenchConfig, report: &mut Report) -> anyhow::Result<()> {
    report.tables.push(table_3_1(ctx, cfg)?);
    report.tables.push(table_3_2(ctx, cfg)?);
    report.tables.push(table_3_3(ctx, cfg)?);
    Ok(())
}

fn table_3_1(ctx: &Context, cfg: &BenchConfig) -> anyhow::Result<Table> {
    let frames = if cfg.quick { 20 } else { 200 };
    let level = 10;
    let mut t = Table::new(
        "thesis_3_1_flag",
        "Thesis Table 3.1: flag animation with and without the compatibility correction",
        &format!(
            "3 × 2 Gregory patches, 10 × 10 grid each, rebuilt from the animated curve network every frame; \
             median over {frames} frames. GPU = timestamps of patch building + evaluation; wall = record + \
             submit + wait of one frame's command buffer; CPU = the f64 reference (flag_patches + \
             tessellate). The thesis (GeForce 9600 GT, drawing included): 185.3 FPS with, 185.9 FPS without."
        ),
        &[
            "correction",
            "GPU ms/frame",
            "wall ms/frame",
            "wall FPS",
            "CPU f64 ms/frame",
        ],
    );
    let flag = FlagSurface::new(ctx, 3, 2, level)?;
    for correct in [true, false] {
        let mut frame = 0u32;
        let g = time_gpu(ctx, 3, frames, |cmd, prof| {
            frame += 1;
            flag.record(ctx, cmd, frame as f32 / 60.0, 0.35, correct, prof)
        })?;
        let mut f = 0u32;
        let cpu = time_cpu(frames.min(50), || {
            f += 1;
            let p = FlagParams {
                t: f as f64 / 60.0,
                correct,
                ..FlagParams::default()
            };
            flag_patches(&p).map(|ps| tessellate(&ps, level))
        });
        t.push(vec![
            if correct {
                "with (CK on)"
            } else {
                "without (CK off)"
            }
            .into(),
            num(g.total()),
            num(g.wall_ms),
            num(1e3 / g.wall_ms),
            num(cpu),
        ]);
    }
    Ok(t)
}

/// Composes the levels of a stack into one matrix (finest = S_k⋯S_1 · cage).
fn composed(stack: &SubdivisionStack) -> SparseMatrix<f64> {
    let mut it = stack.levels.iter();
    let first = it.next().expect("at least one level").s.clone();
    it.fold(first, |acc, l| l.s.matmul(&acc))
}

fn vec4s(p: &[DVec3]) -> Vec<[f32; 4]> {
    p.iter()
        .map(|q| [q.x as f32, q.y as f32, q.z as f32, 1.0])
        .collect()
}

/// GPU SpMV of `m` applied to `cage`: timestamp median of the pass.
fn gpu_spmv_ms(
    ctx: &Context,
    m: &SparseMatrix<f64>,
    cage: &[DVec3],
    repeats: usize,
) -> anyhow::Result<f64> {
    let pass = SpmvPass::new(ctx)?;
    let sparse = GpuSparse::upload(ctx, "bench S", m)?;
    let points = ctx.upload_buffer(
        "bench cage",
        bytemuck::cast_slice(&vec4s(cage)),
        vk::BufferUsageFlags::STORAGE_BUFFER,
    )?;
    let refined = ctx.create_buffer(
        "bench refined",
        m.n_rows.max(1) as u64 * 16,
        vk::BufferUsageFlags::STORAGE_BUFFER,
        MemoryLocation::GpuOnly,
    )?;
    let g = time_gpu(ctx, 2, repeats, |cmd, prof| match prof {
        Some((p, slot)) => p.scope(ctx, cmd, slot, "cc spmv", || {
            pass.record(ctx, cmd, &sparse, &points, &refined)
        }),
        None => pass.record(ctx, cmd, &sparse, &points, &refined),
    })?;
    Ok(g.pass("cc spmv"))
}

fn table_3_2(ctx: &Context, cfg: &BenchConfig) -> anyhow::Result<Table> {
    let cage = grid_cage(3, 3);
    let m = MeshMatrix::from_mesh(&cage);
    let (topo, positions, _) = crate::engine::cage::cage_topology(&cage, Tangents::OpenSubdiv)?;
    let stencils = GregoryStencils::from_mesh(&cage, Tangents::OpenSubdiv)?.stencils;
    let mut t = Table::new(
        "thesis_3_2_subdivision_vs_gregory",
        "Thesis Table 3.2: Catmull–Clark subdivision (matrix form) vs Gregory evaluation, 3 × 3 quad cage",
        &format!(
            "n × n = faces of the result: k Catmull–Clark levels (n = 3·2^k) vs 9 Gregory patches at level \
             n/3 (the same n × n grid). CPU CC = the k sparse products S·P (matrices built once); GPU CC = one \
             SpMV with the composed S (timestamps). CPU Gregory = W·cage + f64 evaluation with normals; GPU \
             Gregory = SpMV + evaluation pass (timestamps). Median of {} repeats. The thesis's figures (CPU, \
             2008, no GPGPU): CC 8.7 / 43.9 / 237.6 / 1489.6 / 13208.6 ms, Gregory 3.2 / 18.1 / 106.8 / 744 / \
             6930.1 ms for 10 generations.",
            cfg.repeats
        ),
        &[
            "n × n",
            "CC levels",
            "CC CPU ms",
            "CC GPU ms",
            "Gregory level",
            "Gregory CPU ms",
            "Gregory GPU ms",
            "CC CPU / Gregory CPU",
        ],
    );
    for k in 1..=5u32 {
        let n = 3 * (1 << k);
        let level = n / 3;
        let stack = SubdivisionStack::catmull_clark(&m, k);
        let cc_cpu = time_cpu(cfg.repeats, || stack.apply(&positions));
        let cc_gpu = gpu_spmv_ms(ctx, &composed(&stack), &positions, cfg.repeats)?;
        let g_cpu = time_cpu(cfg.repeats, || {
            stencils
                .patches_f64(&positions)
                .map(|p| tessellate(&p, level))
        });
        let surface = GregorySurface::new(ctx, &topo, &positions, level)?;
        let g = time_gpu(ctx, 2, cfg.repeats, |cmd, prof| {
            surface.record(ctx, cmd, None, prof)
        })?;
        t.push(vec![
            format!("{n} × {n}").into(),
            k.into(),
            num(cc_cpu),
            num(cc_gpu),
            level.into(),
            num(g_cpu),
            num(g.total()),
            num(cc_cpu / g_cpu),
        ]);
    }
    Ok(t)
}

fn table_3_3(ctx: &Context, cfg: &BenchConfig) -> anyhow::Result<Table> {
    let cage = grid_cage(3, 2);
    let level = 32;
    let (topo, rest, _) = crate::engine::cage::cage_topology(&cage, Tangents::OpenSubdiv)?;
    let stencils = GregoryStencils::from_mesh(&cage, Tangents::OpenSubdiv)?.stencils;
    let frames = if cfg.quick { 10 } else { 100 };
    let mut f = 0u32;
    let cpu = time_cpu(frames, || {
        f += 1;
        let cage = wave_cpu(&rest, f as f64 / 30.0, 1.0);
        stencils.patches_f64(&cage).map(|p| tessellate(&p, level))
    });
    let surface = GregorySurface::new(ctx, &topo, &rest, level)?;
    let mut frame = 0u32;
    let g = time_gpu(ctx, 3, frames, |cmd, prof| {
        frame += 1;
        let d = DeformParams {
            mode: Deformation::Wave,
            t: frame as f32 / 30.0,
            amplitude: 1.0,
            box_min: surface.box_min(),
            box_size: surface.box_size(),
        };
        surface.record(ctx, cmd, Some(&d), prof)
    })?;
    let mut t = Table::new(
        "thesis_3_3_deform_regenerate",
        "Thesis Table 3.3: deform + regenerate, CPU only vs GPU",
        &format!(
            "Six Gregory patches on a plane (3 × 2 quad cage), wave-deformed every frame and regenerated at \
             level {level} ({} vertices); median over {frames} frames. CPU only = the deformation in f64 + \
             W·cage + f64 evaluation with normals; GPU = deform + SpMV + evaluation passes (timestamps) and the \
             wall time of the frame's submission. The thesis: A 44.08 ms CPU vs 0.375 ms GPU; B 53.56 ms CPU vs \
             378.1 ms GPU.",
            6 * (level + 1) * (level + 1)
        ),
        &["path", "ms/frame", "speed-up vs CPU only"],
    );
    t.push(vec!["CPU only".into(), num(cpu), num(1.0)]);
    t.push(vec![
        "GPU (timestamps)".into(),
        num(g.total()),
        num(cpu / g.total()),
    ]);
    t.push(vec![
        "GPU (wall: record + submit + wait)".into(),
        num(g.wall_ms),
        num(cpu / g.wall_ms),
    ]);
    Ok(t)
}
