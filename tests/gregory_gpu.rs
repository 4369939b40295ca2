//! Specification of the GPU Gregory path's kernels: SpMV against the CPU gather, patch evaluation against the
//! f32 and f64 CPU references, corner safety, and bit-identical canonical edges.
mod common;

use ash::vk;
use common::{model, random_patch, with_gpu};
use glam::{DVec3, Vec3};
use gregvox::geom::gregory::PatchF64;
use gregvox::gpu::{Buffer, Context, MemoryLocation};
use gregvox::mesh::{catmull_clark_matrix, load_obj, MeshMatrix};
use gregvox::passes::gregory_eval::{vertex_count, ControlPoints, GregoryEvalPass, SurfaceVertex};
use gregvox::passes::spmv::{GpuSparse, SpmvPass};

fn points_buffer(ctx: &Context, name: &str, pts: &[[f32; 4]]) -> Buffer {
    ctx.upload_buffer(
        name,
        bytemuck::cast_slice(pts),
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
    )
    .unwrap()
}

fn out_buffer(ctx: &Context, name: &str, bytes: u64) -> Buffer {
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

#[test]
fn spmv_equals_the_cpu_gather_bit_for_bit_on_the_bunny_subdivision_matrix() {
    let mesh = load_obj(model("stanford-bunny.obj")).unwrap();
    let s = catmull_clark_matrix(&MeshMatrix::from_mesh(&mesh)).s;
    let x: Vec<[f32; 3]> = mesh
        .positions
        .iter()
        .map(|p| p.as_vec3().to_array())
        .collect();
    let cpu = s.to_f32().spmv_f32(&x);
    let gpu = with_gpu(|ctx| {
        let pass = SpmvPass::new(ctx).unwrap();
        let a = GpuSparse::upload(ctx, "cc", &s).unwrap();
        let xb = points_buffer(
            ctx,
            "x",
            &x.iter()
                .map(|p| [p[0], p[1], p[2], 1.0])
                .collect::<Vec<_>>(),
        );
        let yb = out_buffer(ctx, "y", s.n_rows as u64 * 16);
        ctx.one_shot(|cmd| pass.record(ctx, cmd, &a, &xb, &yb))
            .unwrap();
        bytemuck::pod_collect_to_vec::<u8, [f32; 4]>(&ctx.read_buffer(&yb).unwrap())
    });
    assert_eq!(gpu.len(), cpu.len());
    let differing = gpu
        .iter()
        .zip(&cpu)
        .filter(|(g, c)| [g[0], g[1], g[2]] != **c)
        .count();
    eprintln!(
        "bunny CC matrix: {} rows, {} nnz, {differing} rows differ",
        s.n_rows,
        s.nnz()
    );
    assert_eq!(
        differing, 0,
        "the GPU gather must reproduce the CPU's f32 sums exactly"
    );
}

fn eval_on_gpu(
    patches: &[PatchF64],
    level: u32,
    canonical: bool,
    flags: &[u32],
) -> Vec<SurfaceVertex> {
    eval_on_gpu_tuned(patches, level, canonical, flags, None)
}

/// `tuning`: (subgroup barrier, patches per workgroup); `None` is the device's default.
fn eval_on_gpu_tuned(
    patches: &[PatchF64],
    level: u32,
    canonical: bool,
    flags: &[u32],
    tuning: Option<(bool, u32)>,
) -> Vec<SurfaceVertex> {
    let pts = common::gregory_points(patches);
    let idx: Vec<u32> = (0..patches.len() as u32 * 20).collect();
    with_gpu(|ctx| {
        let pass = match tuning {
            Some((subgroup, ppw)) => GregoryEvalPass::with_tuning(ctx, subgroup, ppw).unwrap(),
            None => GregoryEvalPass::new(ctx).unwrap(),
        };
        let pb = points_buffer(ctx, "points", &pts);
        let ib = ctx
            .upload_buffer(
                "patch points",
                bytemuck::cast_slice(&idx),
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )
            .unwrap();
        let fb = ctx
            .upload_buffer(
                "patch flags",
                bytemuck::cast_slice(flags),
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )
            .unwrap();
        let n = vertex_count(patches.len() as u32, level);
        let out = out_buffer(ctx, "vertices", n * 32);
        ctx.one_shot(|cmd| {
            pass.record(
                ctx,
                cmd,
                ControlPoints::plain(&pb),
                &ib,
                &fb,
                patches.len() as u32,
                level,
                canonical,
                &out,
            )
        })
        .unwrap();
        bytemuck::pod_collect_to_vec::<u8, SurfaceVertex>(&ctx.read_buffer(&out).unwrap())
    })
}

#[test]
fn evaluation_matches_the_f64_and_f32_references_with_exact_derivatives() {
    let patches: Vec<PatchF64> = (0..40).map(random_patch).collect();
    let level = 16;
    let gpu = eval_on_gpu(&patches, level, false, &vec![0; patches.len()]);
    let n = (level + 1) as usize;
    let (mut max_p64, mut max_p32, mut max_n) = (0.0f64, 0.0f32, 0.0f64);
    for (pi, patch) in patches.iter().enumerate() {
        let g32 = patch.to_gpu();
        for j in 0..n {
            for i in 0..n {
                let (u, v) = (i as f64 / level as f64, j as f64 / level as f64);
                let out = gpu[pi * n * n + j * n + i];
                let p = Vec3::from_slice(&out.position[..3]);
                let nrm = Vec3::from_slice(&out.normal[..3]);
                assert!(p.is_finite() && nrm.is_finite());
                max_p64 = max_p64.max((p.as_dvec3() - patch.eval(u, v).0).length());
                max_p32 = max_p32.max((p - g32.eval(u as f32, v as f32).0).length());
                max_n = max_n.max(nrm.as_dvec3().angle_between(patch.normal(u, v)));
            }
        }
    }
    eprintln!("40 patches at L=16: |ΔP| vs f64 {max_p64:.2e}, vs f32 mirror {max_p32:.2e}, normal {max_n:.2e} rad");
    // Patches span ~3 units: f32 rounding of a 20-point rational combination stays below 1e-5.
    assert!(max_p64 < 1e-5, "{max_p64}");
    assert!(max_p32 < 2e-6, "{max_p32}");
    assert!(max_n < 1e-4, "{max_n}");
}

#[test]
fn every_tuning_of_the_evaluation_writes_the_same_bits() {
    // The workgroup barrier with one patch per workgroup (the layout for GPUs with narrow subgroups), the
    // subgroup barrier, and several patches per workgroup with a partial last one (41 patches, 3 or 8 per
    // workgroup): the same arithmetic in the same order, so the same bits at every level.
    let patches: Vec<PatchF64> = (0..41).map(random_patch).collect();
    let flags: Vec<u32> = (0..41).map(|k| k % 16).collect();
    let subgroup_ok =
        with_gpu(|ctx| ctx.info.subgroup_size >= gregvox::passes::gregory_eval::GROUP_SIZE);
    for level in [1, 4, 9] {
        let reference = eval_on_gpu_tuned(&patches, level, true, &flags, Some((false, 1)));
        let default = eval_on_gpu(&patches, level, true, &flags);
        assert_eq!(
            default, reference,
            "the device's default tuning at level {level}"
        );
        for ppw in [3, 8] {
            let tuned = eval_on_gpu_tuned(&patches, level, true, &flags, Some((false, ppw)));
            assert_eq!(
                tuned, reference,
                "workgroup barrier, {ppw} patches per workgroup, level {level}"
            );
            if subgroup_ok {
                let tuned = eval_on_gpu_tuned(&patches, level, true, &flags, Some((true, ppw)));
                assert_eq!(
                    tuned, reference,
                    "subgroup barrier, {ppw} per workgroup, level {level}"
                );
            }
        }
    }
    if !subgroup_ok {
        eprintln!(
            "subgroups narrower than a workgroup here: the subgroup-barrier variant is not used"
        );
    }
}

#[test]
fn corners_and_degenerate_patches_never_produce_nan() {
    let mut patches: Vec<PatchF64> = (0..4).map(random_patch).collect();
    // A patch with a collapsed edge (v = 1 row in one point) and a fully flat one.
    let mut collapsed = random_patch(99);
    for k in [15, 17, 11, 10, 16, 12, 18, 19, 13, 14] {
        collapsed.cv[k] = collapsed.cv[15];
    }
    patches.push(collapsed);
    patches.push(PatchF64 {
        cv: [DVec3::ONE; 20],
    });
    let gpu = eval_on_gpu(&patches, 64, true, &vec![0; patches.len()]);
    assert!(gpu
        .iter()
        .all(|v| v.position.iter().chain(&v.normal).all(|c| c.is_finite())));
    for v in &gpu {
        let l = Vec3::from_slice(&v.normal[..3]).length();
        assert!((l - 1.0).abs() < 1e-5, "normal length {l}");
    }
}

#[test]
fn canonical_edges_are_bit_identical_between_neighbouring_patches() {
    // Two patches sharing the edge u=1 of A and u=0 of B, built from one Bézier net split in two, with the
    // shared edge's canonical direction reversed in B's frame (flag bit 3) against A's (bit 1 clear).
    let a = random_patch(7);
    let mut b = random_patch(8);
    // B's u=0 edge (points 0, 2, 16, 15) equals A's u=1 edge (5, 6, 12, 10).
    b.cv[0] = a.cv[5];
    b.cv[2] = a.cv[6];
    b.cv[16] = a.cv[12];
    b.cv[15] = a.cv[10];
    let level = 13; // odd: no symmetric t values
    for (fa, fb) in [(0u32, 0u32), (1 << 1, 1 << 3)] {
        let gpu = eval_on_gpu(&[a, b], level, true, &[fa, fb]);
        let n = (level + 1) as usize;
        for j in 0..n {
            let pa = gpu[j * n + level as usize].position;
            let pb = gpu[n * n + j * n].position;
            assert_eq!(
                pa, pb,
                "row {j}: the shared edge must be evaluated identically"
            );
        }
    }
}
