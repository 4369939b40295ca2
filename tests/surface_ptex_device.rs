//! The device surface past the uniform refinement's limit: OpenSubdiv's feature-adaptive patches (depths
//! 0…L side by side), tessellated with one grid per ptex face and evaluated on the device (the ptex layout
//! of `engine::gregory`). Its vertices are the f64 limit surface's, its mesh closes where patches of
//! different depths meet, it deforms and changes level, and what needs one grid per patch says so.
#[path = "surface_common.rs"]
mod common;
use common::*;
use glam::DVec3;
use gregvox::mesh::{load_obj_cage, Cage};
use gregvox::passes::gregory_eval::SurfaceVertex;
use gregvox::surface::ptex_grid::{grid_plan, grid_point_count, ptex_grids};
use gregvox::surface::{LimitEvaluator, Tangents};

#[path = "common/mod.rs"]
mod gpu;

/// The largest distance between the device's vertices and the f64 evaluator's grid points, and the
/// largest angle (degrees) between their normals.
fn compare(vertices: &[SurfaceVertex], cage: &Cage, e: &LimitEvaluator, level: u32) -> (f64, f64) {
    let host = ptex_grids(cage, e, level).unwrap();
    assert_eq!(vertices.len(), host.positions.len(), "level {level}");
    let (mut dist, mut angle) = (0.0f64, 0.0f64);
    for (v, (p, n)) in vertices
        .iter()
        .zip(host.positions.iter().zip(&host.normals))
    {
        let q = DVec3::new(
            v.position[0] as f64,
            v.position[1] as f64,
            v.position[2] as f64,
        );
        dist = dist.max((q - *p).length());
        let m = DVec3::new(v.normal[0] as f64, v.normal[1] as f64, v.normal[2] as f64);
        angle = angle.max(m.dot(*n).clamp(-1.0, 1.0).acos().to_degrees());
    }
    (dist, angle)
}

#[test]
fn a_cage_past_the_uniform_limit_gets_a_device_surface_that_is_the_limit_surface_and_closes() {
    // catmark_car: 314 creases of sharpness 6 (RefineAdaptive(6): 136,419 patches; the uniform
    // refinement would make 6.45 M, past the limit, and was refused before).
    let gpu = gpu::validated_gpu();
    let cage = load_obj_cage(model("opensubdiv/catmark_car.obj")).unwrap();
    let e = LimitEvaluator::new(&cage, Tangents::OpenSubdiv).unwrap();
    let d = diag(&cage.mesh.positions);
    let mut s = gpu
        .tagged_gregory_surface(&cage, 4, Tangents::OpenSubdiv)
        .unwrap();
    assert!(
        s.note().is_some_and(|n| n.contains("per ptex face")),
        "{:?}",
        s.note()
    );
    assert_eq!(s.patch_count(), 136_419);
    let levels = s.ptex_levels().unwrap().to_vec();
    assert_eq!(levels, vec![4; e.ptex_faces()]);
    for level in [4, 3] {
        s.set_level(level).unwrap();
        let v = s.read_vertices().unwrap();
        let (dist, angle) = compare(&v, &cage, &e, level);
        println!(
            "car level {level}: {} vertices, position {:.2e}·diag, normal {angle:.3}°",
            v.len(),
            dist / d
        );
        assert!(dist <= 1e-6 * d, "level {level}: {dist} of {d}");
        // f32 against f64, and where the partials degenerate the device's hull fallback against the
        // host's step inside the face.
        assert!(angle <= 0.1, "level {level}: {angle}°");
        // Crack-free: every grid point two faces share has one set of bits in both grids.
        let plan = grid_plan(&cage, e.ptex_map(), level).unwrap();
        // The count the device surface refuses by (before listing any point) is the plan's (no holes here).
        assert!(cage.tags.holes.is_empty());
        assert_eq!(grid_point_count(&cage, level), plan.at.len() as u64);
        let mut first = vec![u32::MAX; plan.unique.len()];
        let mut shared = 0;
        for (i, &k) in plan.slot.iter().enumerate() {
            match first[k as usize] {
                u32::MAX => first[k as usize] = i as u32,
                j => {
                    assert_eq!(v[i].position, v[j as usize].position, "vertex {i} vs {j}");
                    shared += 1;
                }
            }
        }
        assert!(shared > 1000, "{shared}");
        // The triangles index the grids, two a cell.
        let idx = s.indices();
        let cells: u32 = s.ptex_levels().unwrap().iter().map(|l| l * l).sum();
        assert_eq!(idx.len() as u32, 6 * cells);
        assert!(idx.iter().all(|&i| (i as usize) < v.len()));
        assert_eq!(s.buffers().index_count as usize, idx.len());
        assert_eq!(s.vertex_bytes(), 32 * v.len() as u64);
        // UVs (the car has `vt`): the host's f64 UV surface at every grid point, each side of a seam its own.
        let uvs = s.read_uvs().unwrap().unwrap();
        let expect = e.evaluate_uv(&plan.at).unwrap();
        assert_eq!(uvs.len(), v.len());
        for (a, b) in uvs.iter().zip(&expect) {
            assert!((a[0] as f64 - b[0]).abs() <= 1e-6 && (a[1] as f64 - b[1]).abs() <= 1e-6);
        }
        assert!(s.buffers().uvs.is_some());
    }
    // A moved cage moves the surface, as the f64 evaluator of the moved cage says.
    let mut moved = cage.clone();
    for (i, p) in moved.mesh.positions.iter_mut().enumerate() {
        *p += DVec3::new(0.01, -0.02, 0.015) * d * ((i % 7) as f64 / 7.0);
    }
    s.set_cage(&moved.mesh.positions).unwrap();
    s.set_level(3).unwrap();
    s.set_level(2).unwrap();
    let em = LimitEvaluator::new(&moved, Tangents::OpenSubdiv).unwrap();
    let (dist, _) = compare(&s.read_vertices().unwrap(), &moved, &em, 2);
    assert!(dist <= 1e-6 * d, "moved: {dist} of {d}");
    // Evaluation at (face, u, v) goes through the same patches.
    let at = [(0u32, 0.3, 0.7), (17, 0.5, 0.5), (1000, 0.9, 0.1)];
    let got = s.evaluate_at(&at).unwrap();
    let want = em.evaluate(&at).unwrap();
    for (g, w) in got.position.iter().zip(&want) {
        let g = DVec3::new(g[0] as f64, g[1] as f64, g[2] as f64);
        assert!((g - w.position).length() <= 1e-6 * d);
    }
    assert_eq!(got.uv.map(|u| u.len()), Some(3));
    // What needs one grid per patch refuses by name.
    let adaptive = gregvox::api::AdaptiveParams {
        view_proj: glam::Mat4::IDENTITY,
        viewport: [640.0, 480.0],
        pixels_per_segment: 8.0,
    };
    let err = s.set_adaptive(Some(adaptive)).unwrap_err().to_string();
    assert!(err.contains("ptex face"), "{err}");
    let err = s.enable_curvature().unwrap_err().to_string();
    assert!(err.contains("ptex face"), "{err}");
    drop(s);
    gpu.finish().unwrap();
}

#[test]
fn cages_within_the_uniform_limit_keep_one_grid_per_patch() {
    // The ptex layout is only the fallback: a semi-sharp cube stays on the uniform layout, bit for bit.
    let gpu = gpu::validated_gpu();
    let cage = load_obj_cage(model("opensubdiv/catmark_cube_creases0.obj")).unwrap();
    let s = gpu
        .tagged_gregory_surface(&cage, 3, Tangents::OpenSubdiv)
        .unwrap();
    assert!(s.ptex_levels().is_none());
    assert_eq!(
        s.read_vertices().unwrap().len() as u64,
        s.patch_count() as u64 * 16
    );
    drop(s);
    gpu.finish().unwrap();
}

#[test]
fn voxelize_gregory_level_takes_a_cage_past_the_uniform_limit() {
    // The car through `voxelize --gregory-level`: the ptex layout's mesh, peeled on the device.
    let gpu = gpu::validated_gpu();
    let cage = load_obj_cage(model("opensubdiv/catmark_car.obj")).unwrap();
    let opts = gregvox::api::VoxelizeOptions::default().res(48);
    let v = gpu.voxelize_gregory(&cage, 2, &opts, None).unwrap();
    let solid = v.grid.count();
    println!(
        "car at 48³: {solid} solid voxels, {} triangles",
        v.report.triangles
    );
    assert!(solid > 1000, "{solid}");
    let faces = LimitEvaluator::new(&cage, Tangents::OpenSubdiv)
        .unwrap()
        .ptex_faces();
    assert_eq!(v.report.triangles, 2 * 4 * faces);
    drop(v);
    gpu.finish().unwrap();
}

#[test]
fn tessellate_deforms_a_cage_past_the_uniform_limit_on_the_device() {
    // `tessellate --deform` on the car: the ptex layout on the device (deform → W·cage → the grid points);
    // at amplitude 0 it is the host's ptex grids to f32, with the same grids and UVs; a twist moves it.
    use gregvox::api::tessellate::{Patches, TessellateOptions};
    use gregvox::api::Deformation;
    let gpu = gpu::validated_gpu();
    let cage = load_obj_cage(model("opensubdiv/catmark_car.obj")).unwrap();
    let d = diag(&cage.mesh.positions);
    let patches = Patches::from_tagged_cage(&cage, Tangents::OpenSubdiv).unwrap();
    let run = |deform: Option<(Deformation, f32)>| {
        let opts = TessellateOptions {
            level: 2,
            deform,
            ..TessellateOptions::default()
        };
        let mut profiler = gpu.profiler().unwrap();
        gpu.tessellate(&patches, &opts, &mut profiler).unwrap()
    };
    let host = run(None);
    let still = run(Some((Deformation::Twist, 0.0)));
    let twisted = run(Some((Deformation::Twist, 0.5)));
    assert_eq!(still.vertices.len(), host.vertices.len());
    assert_eq!((still.level, &still.levels), (host.level, &host.levels));
    assert_eq!(still.uvs, host.uvs);
    let far = |a: &[SurfaceVertex], b: &[SurfaceVertex]| {
        a.iter()
            .zip(b)
            .map(|(p, q)| {
                (0..3)
                    .map(|k| (p.position[k] as f64 - q.position[k] as f64).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(0.0f64, f64::max)
    };
    let still_gap = far(&still.vertices, &host.vertices);
    let twist_gap = far(&twisted.vertices, &host.vertices);
    println!("car tessellated on the device: {still_gap:.1e} from the host at amplitude 0, twist moves {twist_gap:.3}");
    assert!(still_gap <= 1e-6 * d, "{still_gap}");
    assert!(twist_gap >= 0.01 * d, "{twist_gap}");
    drop((host, still, twisted, patches));
    gpu.finish().unwrap();
}
