//! Specification of the device mesh kernels (`engine::mesh`): the host kernels that CPU devices use write
//! what the Vulkan kernels write into the same kind of buffers — AREA vertex normals within f32 rounding of
//! the shaders (and of libigl's fixture), S·P bit for bit as `SparseMatrix::spmv_f32` — for every thread
//! count; and bad buffers or layouts are errors, never panics.
mod common;
mod mesh_common;

use ash::vk;
use common::with_gpu;
use glam::DVec3;
use gregvox::engine::evaluator::Evaluator;
use gregvox::engine::mesh::{point_buffer, DeviceNormals, DeviceSpmv};
use gregvox::gpu::{Buffer, Context, MemoryLocation};
use gregvox::mesh::{
    catmull_clark_matrix, load_obj, loop_matrix, LoopBeta, Mesh, MeshMatrix, NormalWeighting,
    SparseMatrix,
};
use mesh_common::{model, read_f64x3};

fn buffer(
    ctx: &Context,
    name: &str,
    e: Evaluator,
    points: usize,
    data: Option<&[[f32; 4]]>,
) -> Buffer {
    point_buffer(ctx, name, e, points, data).unwrap()
}

fn vec4(p: &[DVec3]) -> Vec<[f32; 4]> {
    gregvox::mesh::host_kernels::to_vec4(p)
}

fn normals(ctx: &Context, m: &MeshMatrix, p: &[[f32; 4]], e: Evaluator) -> Vec<[f32; 4]> {
    let x = buffer(ctx, "positions", e, p.len(), Some(p));
    let mut n = buffer(ctx, "normals", e, p.len(), None);
    let mut dn = DeviceNormals::new(ctx, m, e).unwrap();
    assert_eq!(dn.evaluator(), e);
    dn.evaluate(ctx, &x, &mut n).unwrap();
    ctx.read_pod(&n).unwrap()
}

fn spmv(ctx: &Context, s: &SparseMatrix<f64>, p: &[[f32; 4]], e: Evaluator) -> Vec<[f32; 4]> {
    let x = buffer(ctx, "x", e, p.len(), Some(p));
    let mut y = buffer(ctx, "y", e, s.n_rows as usize, None);
    let ds = DeviceSpmv::new(ctx, s, e).unwrap();
    ds.evaluate(ctx, &x, &mut y).unwrap();
    ctx.read_pod(&y).unwrap()
}

/// A mesh of quads, a pentagon and triangles with a vertex no face uses.
fn polygons() -> Mesh {
    gregvox::mesh::parse_obj(
        "v 0 0 0\nv 1 0 0\nv 2 0.2 0\nv 0 1 0.1\nv 1 1 0\nv 2 1 0.3\nv 1.5 2 0\nv 0.5 2.2 0.4\nv 9 9 9\n\
         f 1 2 5 4\nf 2 3 6 5\nf 4 5 6 7 8\nf 1 4 8\n",
        "polygons.obj",
    )
    .unwrap()
}

#[test]
fn host_normals_match_the_vulkan_kernels_and_libigl() {
    with_gpu(|ctx| {
        let mut cases: Vec<(String, Mesh, Option<&str>)> = [
            (
                "stanford-bunny.obj",
                Some("stanford-bunny.normals_area.f64"),
            ),
            ("spot.obj", Some("spot.normals_area.f64")),
            ("cow.obj", Some("cow.normals_area.f64")),
        ]
        .into_iter()
        .map(|(f, fx)| (f.to_string(), load_obj(model(f)).unwrap(), fx))
        .collect();
        cases.push(("polygons".into(), polygons(), None));
        for (name, mesh, fixture) in cases {
            let m = MeshMatrix::from_mesh(&mesh);
            let p = vec4(&mesh.positions);
            let host = normals(ctx, &m, &p, Evaluator::Host);
            let vulkan = normals(ctx, &m, &p, Evaluator::Vulkan);
            let cpu = m.vertex_normals(&mesh.positions, NormalWeighting::Area);
            let (mut dv, mut dc, mut same) = (0.0f32, 0.0f64, 0usize);
            for v in 0..host.len() {
                assert_eq!(host[v][3], 0.0, "{name} {v}: w");
                assert!(host[v].iter().all(|x| x.is_finite()), "{name} {v}");
                for a in 0..3 {
                    dv = dv.max((host[v][a] - vulkan[v][a]).abs());
                    dc = dc.max((host[v][a] as f64 - cpu[v][a]).abs());
                }
                same += (host[v].map(f32::to_bits) == vulkan[v].map(f32::to_bits)) as usize;
                if !m.is_referenced(v) {
                    assert_eq!(host[v], [0.0; 4], "{name}: unreferenced vertex {v}");
                }
            }
            eprintln!(
                "{name}: host vs Vulkan {dv:.2e} ({same} of {} bit-equal), vs CPU f64 {dc:.2e}",
                host.len()
            );
            // One f32 normalisation apart at most (a driver may compute length() or the division
            // differently); f32 sums of a few dozen cross products against the f64 code.
            assert!(dv <= 1e-6, "{name}: host vs Vulkan {dv}");
            assert!(dc <= 2e-5, "{name}: host vs CPU {dc}");
            if let Some(f) = fixture {
                let oracle = read_f64x3(f);
                let worst = (0..host.len())
                    .filter(|&v| m.is_referenced(v))
                    .map(|v| {
                        (0..3)
                            .map(|a| (host[v][a] as f64 - oracle[v][a]).abs())
                            .fold(0.0, f64::max)
                    })
                    .fold(0.0, f64::max);
                assert!(worst <= 2e-5, "{name}: host vs libigl {worst}");
            }
        }
    });
}

#[test]
fn host_subdivision_products_equal_spmv_f32_and_the_vulkan_kernel_bit_for_bit() {
    with_gpu(|ctx| {
        let mesh = load_obj(model("stanford-bunny.obj")).unwrap();
        let m = MeshMatrix::from_mesh(&mesh);
        let p = vec4(&mesh.positions);
        let xyz: Vec<[f32; 3]> = p.iter().map(|q| [q[0], q[1], q[2]]).collect();
        for (what, s) in [
            ("Catmull–Clark", catmull_clark_matrix(&m).s),
            ("Loop", loop_matrix(&m, LoopBeta::Warren).unwrap().s),
        ] {
            let host = spmv(ctx, &s, &p, Evaluator::Host);
            let vulkan = spmv(ctx, &s, &p, Evaluator::Vulkan);
            let reference = s.to_f32().spmv_f32(&xyz);
            assert_eq!(host.len(), reference.len());
            let mut same = 0;
            for r in 0..host.len() {
                let want = [reference[r][0], reference[r][1], reference[r][2], 1.0];
                assert_eq!(
                    host[r].map(f32::to_bits),
                    want.map(f32::to_bits),
                    "{what} row {r}"
                );
                same += (host[r].map(f32::to_bits) == vulkan[r].map(f32::to_bits)) as usize;
                for a in 0..3 {
                    assert!((host[r][a] - vulkan[r][a]).abs() <= 1e-6, "{what} row {r}");
                }
            }
            eprintln!(
                "{what}: {same} of {} rows bit-equal to the Vulkan kernel",
                host.len()
            );
        }
    });
}

#[test]
fn host_kernels_write_the_same_bits_on_one_thread_and_on_all() {
    with_gpu(|ctx| {
        let mesh = load_obj(model("spot.obj")).unwrap();
        let m = MeshMatrix::from_mesh(&mesh);
        let p = vec4(&mesh.positions);
        let s = catmull_clark_matrix(&m).s;
        let all = (
            normals(ctx, &m, &p, Evaluator::Host),
            spmv(ctx, &s, &p, Evaluator::Host),
        );
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let one = pool.install(|| {
            (
                normals(ctx, &m, &p, Evaluator::Host),
                spmv(ctx, &s, &p, Evaluator::Host),
            )
        });
        let bits = |v: &[[f32; 4]]| {
            v.iter()
                .flat_map(|q| q.map(f32::to_bits))
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&all.0), bits(&one.0));
        assert_eq!(bits(&all.1), bits(&one.1));
    });
}

#[test]
fn host_normals_follow_a_deformed_mesh_as_the_vulkan_kernels_do() {
    with_gpu(|ctx| {
        let mesh = load_obj(model("spot.obj")).unwrap();
        let m = MeshMatrix::from_mesh(&mesh);
        let e = Evaluator::Host;
        let mut x = buffer(ctx, "positions", e, mesh.positions.len(), None);
        let mut n = buffer(ctx, "normals", e, mesh.positions.len(), None);
        let mut dn = DeviceNormals::new(ctx, &m, e).unwrap();
        let rest = m.vertex_normals(&mesh.positions, NormalWeighting::Area);
        for t in [0.0, 0.4, 1.0] {
            // A smooth non-rigid deformation, the same buffer rewritten: normals are recomputed each call.
            let moved: Vec<DVec3> = mesh
                .positions
                .iter()
                .map(|p| {
                    DVec3::new(
                        p.x * (1.0 + 0.3 * t * p.y),
                        p.y + 0.2 * t * (3.0 * p.x).sin(),
                        p.z,
                    )
                })
                .collect();
            let p4 = vec4(&moved);
            x.mapped_mut()
                .unwrap()
                .copy_from_slice(bytemuck::cast_slice(&p4));
            dn.evaluate(ctx, &x, &mut n).unwrap();
            let got: Vec<[f32; 4]> = ctx.read_pod(&n).unwrap();
            let vulkan = normals(ctx, &m, &p4, Evaluator::Vulkan);
            let cpu = m.vertex_normals(&moved, NormalWeighting::Area);
            let (mut worst, mut moved_most, mut differ) = (0.0f64, 0.0f64, 0usize);
            for v in 0..got.len() {
                differ += (got[v].map(f32::to_bits) != vulkan[v].map(f32::to_bits)) as usize;
                for a in 0..3 {
                    assert!((got[v][a] - vulkan[v][a]).abs() <= 1e-6, "t {t} vertex {v}");
                    worst = worst.max((got[v][a] as f64 - cpu[v][a]).abs());
                }
                moved_most = moved_most.max((cpu[v] - rest[v]).length());
            }
            eprintln!("t {t}: vs CPU f64 {worst:.2e}, {differ} differing from the Vulkan kernels");
            assert!(worst <= 2e-5, "t {t}: {worst}");
            if t == 1.0 {
                assert!(
                    moved_most > 0.1,
                    "negative control: the normals must move ({moved_most})"
                );
            }
        }
    });
}

#[test]
fn bad_buffers_and_layouts_are_errors_that_name_them() {
    with_gpu(|ctx| {
        let mesh = polygons();
        let m = MeshMatrix::from_mesh(&mesh);
        let nv = mesh.positions.len();
        for e in [Evaluator::Host, Evaluator::Vulkan] {
            let mut dn = DeviceNormals::new(ctx, &m, e).unwrap();
            let x = buffer(ctx, "short positions", e, nv - 1, None);
            let mut n = buffer(ctx, "normals", e, nv, None);
            let err = dn.evaluate(ctx, &x, &mut n).unwrap_err().to_string();
            assert!(err.contains("short positions"), "{err}");
            let x = buffer(ctx, "positions", e, nv, None);
            let mut short = buffer(ctx, "short normals", e, 2, None);
            let err = dn.evaluate(ctx, &x, &mut short).unwrap_err().to_string();
            assert!(err.contains("short normals"), "{err}");
        }
        // The host kernels map the buffers: device-local memory is refused by name.
        let mut dn = DeviceNormals::new(ctx, &m, Evaluator::Host).unwrap();
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let x = ctx
            .create_buffer(
                "local positions",
                nv as u64 * 16,
                usage,
                MemoryLocation::GpuOnly,
            )
            .unwrap();
        let mut n = buffer(ctx, "normals", Evaluator::Host, nv, None);
        let err = dn.evaluate(ctx, &x, &mut n).unwrap_err().to_string();
        assert!(err.contains("local positions"), "{err}");
        // No faces.
        let empty = MeshMatrix::new(3, &[0], vec![]).unwrap();
        for e in [Evaluator::Host, Evaluator::Vulkan] {
            let err = DeviceNormals::new(ctx, &empty, e)
                .err()
                .expect("no faces")
                .to_string();
            assert!(err.contains("no faces"), "{err}");
        }
        // A matrix whose column, row pointers or values lie: refused before any upload or evaluation.
        let good = catmull_clark_matrix(&m).s;
        let mut bad_col = good.clone();
        bad_col.col[3] = bad_col.n_cols;
        let mut bad_ptr = good.clone();
        let last = bad_ptr.row_ptr.len() - 1;
        bad_ptr.row_ptr[last] += 1;
        let mut bad_rows = good.clone();
        bad_rows.n_rows += 1;
        for e in [Evaluator::Host, Evaluator::Vulkan] {
            for (what, s) in [
                ("column", &bad_col),
                ("row pointers", &bad_ptr),
                ("row pointers", &bad_rows),
            ] {
                let err = DeviceSpmv::new(ctx, s, e).err().expect(what).to_string();
                assert!(err.contains(what), "{what}: {err}");
            }
            let ds = DeviceSpmv::new(ctx, &good, e).unwrap();
            let x = buffer(ctx, "cage", e, good.n_cols as usize, None);
            let mut y = buffer(ctx, "short refined", e, good.n_rows as usize - 1, None);
            let err = ds.evaluate(ctx, &x, &mut y).unwrap_err().to_string();
            assert!(err.contains("short refined"), "{err}");
        }
    });
}
