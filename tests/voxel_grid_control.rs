//! Specification of grid control and fill modes: the box of the used vertices; `--dims`, `--voxel-size`,
//! `--bbox` and `--pad` against a reference that evaluates the inside test (the winding number of the whole
//! mesh, brute force) at the documented centres origin + (index + ½)·size; `--fill surface` against an
//! independent separating-axis oracle, voxel for voxel; a sheet a tenth of a voxel thick kept by `--fill
//! both`; `--method auto`; and every output's placement read back (validation layer forced on).
#![allow(clippy::needless_range_loop)] // per-axis formulas read best with the axis as an index
mod common;

use common::model;

fn model_str(name: &str) -> String {
    model(name).to_str().unwrap().to_string()
}
use gregvox::mesh::Mesh;
use gregvox::voxel::grid::Axis;
use gregvox::voxel::mesh::TriMesh;
use gregvox::{load_mesh, voxelize_on_cpu, Axes, Fill, Gpu, Method, VoxelizeOptions};
use std::process::{Command, Output};

fn gregvox(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gregvox"))
        .args(args)
        .env("GREGVOX_VALIDATION", "1")
        .output()
        .unwrap()
}

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("gregvox-grid-control-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

fn as_mesh(t: &TriMesh) -> Mesh {
    let p = t
        .positions
        .iter()
        .map(|p| glam::DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
        .collect();
    let f: Vec<Vec<u32>> = t.triangles.iter().map(|t| t.to_vec()).collect();
    Mesh::from_polygons(p, &f).unwrap()
}

/// The solid angle of triangle `t` seen from `p` (Van Oosterom–Strackee).
fn solid_angle(p: [f64; 3], t: [[f64; 3]; 3]) -> f64 {
    let v: Vec<[f64; 3]> = t
        .iter()
        .map(|q| [q[0] - p[0], q[1] - p[1], q[2] - p[2]])
        .collect();
    let len = |a: &[f64; 3]| (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    let dot = |a: &[f64; 3], b: &[f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let (a, b, c) = (&v[0], &v[1], &v[2]);
    let det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
        + a[2] * (b[0] * c[1] - b[1] * c[0]);
    let (la, lb, lc) = (len(a), len(b), len(c));
    let den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
    2.0 * det.atan2(den)
}

/// Distance from `p` to triangle `t` (closest point by the Voronoi regions of the triangle).
fn dist_to_triangle(p: [f64; 3], t: [[f64; 3]; 3]) -> f64 {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let (a, b, c) = (t[0], t[1], t[2]);
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    let at = |s: f64, u: f64| {
        let q = [
            a[0] + s * ab[0] + u * ac[0],
            a[1] + s * ab[1] + u * ac[1],
            a[2] + s * ab[2] + u * ac[2],
        ];
        let d = sub(p, q);
        dot(d, d).sqrt()
    };
    if d1 <= 0.0 && d2 <= 0.0 {
        return at(0.0, 0.0);
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return at(1.0, 0.0);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return at(d1 / (d1 - d3), 0.0);
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return at(0.0, 1.0);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return at(0.0, d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return at(1.0 - w, w);
    }
    let den = 1.0 / (va + vb + vc);
    at(vb * den, vc * den)
}

/// A closed sphere (off-centre, so no symmetry hides a swapped axis) and a solid box beside it.
fn two_solids() -> TriMesh {
    let mut m = TriMesh::sphere([0.3, -0.2, 0.1], 1.0, 10, 20, false);
    m.append(&TriMesh::cube([1.05, 0.35, -0.6], 0.7));
    m
}

/// Compares a voxelization with the winding number of the whole mesh at the documented centres: every voxel
/// whose centre is farther than `band` (world units) from the surface must agree. Returns (checked, solid).
fn check_against_winding_number(
    grid: &gregvox::voxel::grid::VoxelGrid,
    mesh: &TriMesh,
    band: f64,
) -> (u64, u64) {
    let tris: Vec<[[f64; 3]; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|v| mesh.positions[v as usize].map(|c| c as f64)))
        .collect();
    let f = grid.frame;
    let (mut checked, mut solid) = (0, 0);
    for i in 0..f.dims[0] {
        for j in 0..f.dims[1] {
            for k in 0..f.dims[2] {
                // The documented centre, computed here from its definition, not by the library.
                let c: [f64; 3] = std::array::from_fn(|a| {
                    f.origin[a] + ([i, j, k][a] as f64 + 0.5) * f.voxel_size[a]
                });
                assert_eq!(c, f.centre(i, j, k));
                let near = tris.iter().any(|&t| dist_to_triangle(c, t) <= band);
                if near {
                    continue;
                }
                let w: f64 = tris.iter().map(|&t| solid_angle(c, t)).sum::<f64>()
                    / (4.0 * std::f64::consts::PI);
                let inside = w.round() != 0.0;
                assert_eq!(
                    grid.get(i, j, k),
                    inside,
                    "voxel ({i},{j},{k}) centre {c:?}: winding number {w}"
                );
                checked += 1;
                solid += inside as u64;
            }
        }
    }
    (checked, solid)
}

#[test]
fn the_box_is_that_of_the_vertices_the_faces_use() {
    let mut cube = TriMesh::cube([0.0; 3], 1.0);
    cube.positions.push([7.0, 7.0, 7.0]); // no face uses it
    let v = voxelize_on_cpu(&as_mesh(&cube), &VoxelizeOptions::default().res(16)).unwrap();
    assert_eq!(v.grid.frame.origin, [0.0; 3]);
    assert_eq!(v.grid.frame.voxel_size, [1.0 / 16.0; 3]);
    assert_eq!(v.grid.count(), 16 * 16 * 16);
}

#[test]
fn dims_voxel_size_bbox_and_pad_agree_with_the_winding_number_at_the_documented_centres() {
    let mesh = two_solids();
    let m = as_mesh(&mesh);
    let cases: Vec<(&str, VoxelizeOptions)> = vec![
        ("dims", VoxelizeOptions::default().dims([23, 14, 9])),
        ("voxel size", VoxelizeOptions::default().voxel_size(0.17)),
        (
            "bbox cutting through both solids",
            VoxelizeOptions::default()
                .dims([17, 11, 6])
                .bbox([-0.2, -0.9, -0.5], [1.5, 0.6, 0.35]),
        ),
        (
            "bbox beyond the mesh, padded",
            VoxelizeOptions::default()
                .voxel_size(0.2)
                .bbox([-1.5, -1.5, -1.5], [2.5, 1.5, 1.5])
                .pad(2),
        ),
        (
            "dims padded",
            VoxelizeOptions::default().dims([12, 9, 7]).pad(3),
        ),
    ];
    for (name, opts) in cases {
        let v = voxelize_on_cpu(&m, &opts).unwrap();
        let f = v.grid.frame;
        // The band: the rasterizer snaps vertices to 1/256 voxel, so centres that close may go either way.
        let band = 2.0 / 256.0 * f.voxel_size.iter().copied().fold(0.0, f64::max);
        let (checked, solid) = check_against_winding_number(&v.grid, &mesh, band);
        eprintln!(
            "{name}: {:?} voxels of {:?}, {checked} checked, {solid} solid",
            f.dims, f.voxel_size
        );
        assert!(
            solid > 20 && checked > solid,
            "{name}: the grid tests nothing"
        );
        // The GPU methods: the same frame, and the winding number's answer away from the surface, along z
        // and along the axis they choose. (Centres exactly on a face, such as the box's faces on voxel-centre
        // planes here, are ties that f32 GPU arithmetic and the f64 CPU may break differently.)
        let gpu = Gpu::new().unwrap();
        for method in [Method::Peel, Method::Abuffer] {
            for axes in [Axes::One(Axis::Z), Axes::Auto] {
                let g = gpu
                    .voxelize(&m, &opts.clone().method(method).axes(axes))
                    .unwrap();
                assert_eq!(g.grid.frame, f, "{name} {method:?}");
                let (c, s) = check_against_winding_number(&g.grid, &mesh, band);
                assert_eq!((c, s), (checked, solid), "{name} {method:?}");
            }
        }
        gpu.finish().unwrap();
    }
}

#[test]
fn grid_flags_follow_their_definitions() {
    let m = as_mesh(&two_solids());
    let frame = |o: VoxelizeOptions| gregvox::api::grid_frame(&m, &o).unwrap();
    let b = gregvox::voxel::grid::Bounds::of_triangles(
        &two_solids().positions,
        &two_solids().triangles,
    )
    .unwrap();
    let ext = b.extent();
    let f = frame(VoxelizeOptions::default().dims([10, 20, 30]));
    assert_eq!(f.dims, [10, 20, 30]);
    for a in 0..3 {
        assert_eq!(f.voxel_size[a], ext[a] / f.dims[a] as f64);
    }
    let f = frame(VoxelizeOptions::default().voxel_size(0.3).pad(2));
    for a in 0..3 {
        assert_eq!(f.dims[a], (ext[a] / 0.3).ceil() as u32 + 4);
        assert_eq!(f.origin[a], b.min[a] - 2.0 * 0.3);
    }
    let f = frame(
        VoxelizeOptions::default()
            .res(32)
            .bbox([0.0, 0.0, 0.0], [4.0, 2.0, 1.0]),
    );
    assert_eq!(
        (f.dims, f.origin, f.voxel_size),
        ([32; 3], [0.0; 3], [0.125; 3])
    );
}

/// The separating-axis oracle, written from Akenine-Möller's paper independently of the library: the triangle
/// against the unit box [i, i+1]×[j, j+1]×[k, k+1] in grid units, every voxel of the triangle's box tested.
fn sat_oracle(
    mesh: &TriMesh,
    f: &gregvox::voxel::grid::GridFrame,
) -> std::collections::HashSet<[u32; 3]> {
    let mut out = std::collections::HashSet::new();
    for t in &mesh.triangles {
        let g: [[f64; 3]; 3] = t.map(|v| {
            let p = mesh.positions[v as usize];
            std::array::from_fn(|a| (p[a] as f64 - f.origin[a]) / f.voxel_size[a])
        });
        let lo: [f64; 3] = std::array::from_fn(|a| g[0][a].min(g[1][a]).min(g[2][a]));
        let hi: [f64; 3] = std::array::from_fn(|a| g[0][a].max(g[1][a]).max(g[2][a]));
        let range = |a: usize| {
            let i0 = (lo[a] - 1.0).ceil().max(0.0) as i64;
            let i1 = (hi[a].floor() as i64).min(f.dims[a] as i64 - 1);
            i0..=i1
        };
        for i in range(0) {
            for j in range(1) {
                for k in range(2) {
                    let c = [i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5];
                    let v: Vec<[f64; 3]> = g
                        .iter()
                        .map(|p| std::array::from_fn(|a| p[a] - c[a]))
                        .collect();
                    let e: Vec<[f64; 3]> = (0..3)
                        .map(|n| std::array::from_fn(|a| v[(n + 1) % 3][a] - v[n][a]))
                        .collect();
                    let cross = |a: [f64; 3], b: [f64; 3]| {
                        [
                            a[1] * b[2] - a[2] * b[1],
                            a[2] * b[0] - a[0] * b[2],
                            a[0] * b[1] - a[1] * b[0],
                        ]
                    };
                    let mut axes: Vec<[f64; 3]> =
                        vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
                    for ed in &e {
                        for u in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
                            axes.push(cross(*ed, u));
                        }
                    }
                    axes.push(cross(e[0], e[1]));
                    let overlap = axes.iter().all(|n| {
                        let p: Vec<f64> = v
                            .iter()
                            .map(|q| n[0] * q[0] + n[1] * q[1] + n[2] * q[2])
                            .collect();
                        let r = 0.5 * (n[0].abs() + n[1].abs() + n[2].abs());
                        let (mn, mx) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
                        !(mn > r || mx < -r)
                    });
                    if overlap {
                        out.insert([i as u32, j as u32, k as u32]);
                    }
                }
            }
        }
    }
    out
}

fn set_of(g: &gregvox::voxel::grid::VoxelGrid) -> std::collections::HashSet<[u32; 3]> {
    let mut s = std::collections::HashSet::new();
    let [x, y, z] = g.frame.dims;
    for i in 0..x {
        for j in 0..y {
            for k in 0..z {
                if g.get(i, j, k) {
                    s.insert([i, j, k]);
                }
            }
        }
    }
    s
}

#[test]
fn fill_surface_equals_the_separating_axis_oracle_on_a_sphere_a_cube_and_the_bunny() {
    let bunny = load_mesh(model("stanford-bunny.obj")).unwrap();
    let meshes = [
        (
            "sphere",
            as_mesh(&TriMesh::sphere([0.1, 0.2, -0.3], 1.0, 24, 48, false)),
        ),
        // Faces on voxel boundaries: touching counts, on both sides.
        ("cube", as_mesh(&TriMesh::cube([0.0; 3], 1.0))),
        ("bunny", bunny),
    ];
    for (name, m) in &meshes {
        for res in [64, 128] {
            let opts = VoxelizeOptions::default().res(res).fill(Fill::Surface);
            let v = voxelize_on_cpu(m, &opts).unwrap();
            let tri = TriMesh::fan(m);
            let want = sat_oracle(&tri, &v.grid.frame);
            let got = set_of(&v.grid);
            eprintln!("{name} {res}³: {} surface voxels", got.len());
            assert!(!want.is_empty());
            assert_eq!(got.len(), want.len(), "{name} {res}");
            assert!(got == want, "{name} {res}: the voxel sets differ");
        }
    }
    // The cube at 64³ fills its whole shell: 64³ − 62³ voxels.
    let v = voxelize_on_cpu(
        &meshes[1].1,
        &VoxelizeOptions::default().res(64).fill(Fill::Surface),
    )
    .unwrap();
    assert_eq!(v.grid.count(), 64u64.pow(3) - 62u64.pow(3));
}

#[test]
fn the_gpu_surface_pass_marks_the_same_voxels_as_the_cpu_bit_for_bit() {
    let bunny = load_mesh(model("stanford-bunny.obj")).unwrap();
    let sphere = as_mesh(&TriMesh::sphere([0.1, 0.2, -0.3], 1.0, 24, 48, false));
    let cube = as_mesh(&TriMesh::cube([0.0; 3], 1.0));
    let gpu = Gpu::new().unwrap();
    assert!(
        gpu.info().features.shader_float64,
        "lavapipe computes in f64"
    );
    let cases = [
        ("sphere 64", &sphere, VoxelizeOptions::default().res(64)),
        ("sphere 128", &sphere, VoxelizeOptions::default().res(128)),
        ("cube 64", &cube, VoxelizeOptions::default().res(64)),
        ("cube 128", &cube, VoxelizeOptions::default().res(128)),
        ("bunny 64", &bunny, VoxelizeOptions::default().res(64)),
        ("bunny 128", &bunny, VoxelizeOptions::default().res(128)),
        (
            "sphere anisotropic, boxed, padded",
            &sphere,
            VoxelizeOptions::default()
                .dims([70, 33, 50])
                .bbox([-0.5, -0.9, -1.4], [1.2, 1.3, 0.3])
                .pad(2),
        ),
    ];
    for (name, m, opts) in cases {
        let cpu = voxelize_on_cpu(m, &opts.clone().fill(Fill::Surface))
            .unwrap()
            .grid;
        let g = gpu
            .voxelize(m, &opts.clone().fill(Fill::Surface).method(Method::Peel))
            .unwrap();
        assert!(
            g.report.notes.iter().all(|n| !n.contains("on the CPU")),
            "{name}"
        );
        assert!(cpu.count() > 100, "{name}");
        assert_eq!(g.grid.count_differences(&cpu), 0, "{name}");
    }
    gpu.finish().unwrap();
}

#[test]
fn the_gpu_surface_pass_gives_the_same_bits_slab_by_slab() {
    use gregvox::engine::voxelize::{voxelize_surface_gpu, GpuTriangles};
    let tri = TriMesh::fan(&load_mesh(model("stanford-bunny.obj")).unwrap())
        .clean()
        .0;
    let frame = gregvox::api::grid_frame(
        &as_mesh(&tri),
        &VoxelizeOptions::default().dims([40, 37, 70]),
    )
    .unwrap();
    let cpu = gregvox::voxel::surface::voxelize_surface(&tri, &frame);
    common::with_gpu(|ctx| {
        let gpu = GpuTriangles::upload(ctx, &tri).unwrap();
        // One row of 40 columns × 3 words is 480 bytes: slabs of 1, 5 and 37 rows (5 does not divide 37).
        for rows in [1u64, 5, 37] {
            let g = voxelize_surface_gpu(ctx, &gpu, &tri, &frame, Some(rows * 480))
                .unwrap()
                .unwrap();
            assert_eq!(g.count_differences(&cpu), 0, "slabs of {rows} rows");
        }
    });
}

#[test]
fn a_sheet_a_tenth_of_a_voxel_thick_keeps_every_voxel_it_crosses_with_fill_both() {
    // A closed slab 0.1 voxel thick, tilted so it crosses voxel centres' planes everywhere.
    let h = 1.0 / 32.0;
    let mut slab = TriMesh::cube([0.0; 3], 1.0);
    for p in &mut slab.positions {
        let z = p[2] * 0.1 * h as f32; // thickness 0.1 voxel
        *p = [p[0], p[1], 0.37 + 0.3 * p[0] + 0.2 * p[1] + z];
    }
    // A box around the sheet so the voxels stay 1/32 wide.
    let opts = VoxelizeOptions::default()
        .voxel_size(h)
        .bbox([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
    let m = as_mesh(&slab);
    let solid = voxelize_on_cpu(&m, &opts.clone().fill(Fill::Solid))
        .unwrap()
        .grid;
    let surface = voxelize_on_cpu(&m, &opts.clone().fill(Fill::Surface))
        .unwrap()
        .grid;
    let both = voxelize_on_cpu(&m, &opts.clone().fill(Fill::Both))
        .unwrap()
        .grid;
    let crossed = sat_oracle(&slab, &both.frame);
    eprintln!(
        "sheet: {} solid, {} surface, {} both, {} crossed",
        solid.count(),
        surface.count(),
        both.count(),
        crossed.len()
    );
    assert!(
        solid.count() < crossed.len() as u64 / 4,
        "the solid alone loses the sheet"
    );
    let kept = set_of(&both);
    assert!(
        crossed.iter().all(|v| kept.contains(v)),
        "a voxel the sheet crosses was lost"
    );
    assert!(crossed.len() >= 32 * 32, "the sheet crosses every column");
    assert_eq!(both.count_differences(&surface.union(&solid)), 0);
    // And on the GPU methods, the same.
    let gpu = Gpu::new().unwrap();
    for method in [Method::Peel, Method::Abuffer] {
        let g = gpu
            .voxelize(&m, &opts.clone().fill(Fill::Both).method(method))
            .unwrap();
        assert_eq!(g.grid.count_differences(&both), 0, "{method:?}");
    }
    gpu.finish().unwrap();
}

#[test]
fn auto_runs_the_cpu_scanline_on_a_cpu_device_and_the_abuffer_on_a_gpu_and_says_why() {
    let out = gregvox(&["voxelize", &model_str("spot.obj"), "--res", "32", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // The device the binary picks (lavapipe in CI: a CPU device).
    let (_, kind) = gregvox::gpu::context::probe_device().unwrap();
    let (expected, why_word) = if kind == "CPU" {
        ("cpu", "CPU")
    } else {
        ("abuffer", "GPU")
    };
    assert_eq!(j["method"], expected, "{kind}: {j}");
    let why = j["method_reason"].as_str().unwrap();
    assert!(why.starts_with("auto: ") && why.contains(why_word), "{why}");
    // The same grid as every named method.
    for m in ["cpu", "peel", "abuffer"] {
        let o = gregvox(&[
            "voxelize",
            &model_str("spot.obj"),
            "--res",
            "32",
            "--json",
            "--method",
            m,
        ]);
        let k: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        // Auto's grid is that of the method it names (the other methods may differ from it at centres
        // within the rasterizer's snapping of a triangle on a GPU: tests/common::assert_same_up_to_snapping).
        if m == expected {
            assert_eq!(k["solid_voxels"], j["solid_voxels"], "{m}");
        }
        assert_eq!(k["method"], m);
        assert!(k["method_reason"].is_null());
    }
    let text = gregvox(&["voxelize", &model_str("spot.obj"), "--res", "32"]);
    let s = String::from_utf8_lossy(&text.stdout);
    assert!(s.contains(&format!("method: {expected} (auto: ")), "{s}");
}

/// Reads a NRRD header's placement: (sizes, spacing, centre of voxel 0).
fn nrrd_placement(bytes: &[u8]) -> ([u32; 3], [f64; 3], [f64; 3]) {
    let end = bytes.windows(2).position(|w| w == b"\n\n").unwrap();
    let h = std::str::from_utf8(&bytes[..end]).unwrap();
    let field = |k: &str| {
        h.lines()
            .find_map(|l| l.strip_prefix(k))
            .unwrap()
            .trim()
            .to_string()
    };
    let sizes: Vec<u32> = field("sizes:")
        .split_whitespace()
        .map(|s| s.parse().unwrap())
        .collect();
    let nums = |s: &str| -> Vec<f64> {
        s.split(|c: char| "(), ".contains(c))
            .filter(|t| !t.is_empty())
            .map(|t| t.parse().unwrap())
            .collect()
    };
    let d = nums(&field("space directions:"));
    let o = nums(&field("space origin:"));
    (
        [sizes[0], sizes[1], sizes[2]],
        [d[0], d[4], d[8]],
        [o[0], o[1], o[2]],
    )
}

#[test]
fn every_output_reads_back_the_documented_placement_within_a_millionth_of_a_voxel() {
    let input = tmp("solids.obj");
    gregvox::mesh::write_obj(&input, &as_mesh(&two_solids())).unwrap();
    let input = input.to_str().unwrap().to_string();
    // The documented placement, computed here: origin = box min − pad·size, size = extent / dims.
    let (bmin, bmax, dims, pad) = ([-1.0, -1.5, -1.0], [2.0, 1.0, 1.25], [30u32, 20, 9], 2u32);
    let size: [f64; 3] = std::array::from_fn(|a| (bmax[a] - bmin[a]) / dims[a] as f64);
    let origin: [f64; 3] = std::array::from_fn(|a| bmin[a] - pad as f64 * size[a]);
    let full: [u32; 3] = dims.map(|d| d + 2 * pad);
    let bbox = "-1,-1.5,-1,2,1,1.25";
    let close = |what: &str, a: [f64; 3], b: [f64; 3]| {
        for k in 0..3 {
            assert!(
                (a[k] - b[k]).abs() <= 1e-6 * size[k],
                "{what}: {a:?} vs {b:?}"
            );
        }
    };
    for ext in ["nrrd", "npy", "raw", "vox"] {
        let out = tmp(&format!("g.{ext}"));
        let o = gregvox(&[
            "voxelize",
            &input,
            "--dims",
            "30,20,9",
            "--bbox",
            bbox,
            "--pad",
            "2",
            "--out",
            out.to_str().unwrap(),
            "--json",
        ]);
        assert!(
            o.status.success(),
            "{ext}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(j["dims"], serde_json::json!(full));
        if ext == "nrrd" {
            let (s, d, c0) = nrrd_placement(&std::fs::read(&out).unwrap());
            assert_eq!(s, full);
            close("nrrd spacing", d, size);
            close(
                "nrrd origin",
                c0,
                std::array::from_fn(|a| origin[a] + 0.5 * size[a]),
            );
        } else {
            let side: serde_json::Value = serde_json::from_slice(
                &std::fs::read(gregvox::voxel::export::sidecar_path(&out)).unwrap(),
            )
            .unwrap();
            assert_eq!(side["dims"], serde_json::json!(full));
            let v: [f64; 3] = serde_json::from_value(side["voxel_size"].clone()).unwrap();
            let o: [f64; 3] = serde_json::from_value(side["origin"].clone()).unwrap();
            close(&format!("{ext} voxel size"), v, size);
            close(&format!("{ext} origin"), o, origin);
            let m: Vec<Vec<f64>> = serde_json::from_value(side["index_to_world"].clone()).unwrap();
            let idx = [33.0, 23.0, 12.0];
            let w: [f64; 3] =
                std::array::from_fn(|a| (0..3).map(|b| m[a][b] * idx[b]).sum::<f64>() + m[a][3]);
            close(
                &format!("{ext} matrix"),
                w,
                std::array::from_fn(|a| origin[a] + (idx[a] + 0.5) * size[a]),
            );
        }
        if ext == "npy" {
            let b = std::fs::read(&out).unwrap();
            let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
            let header = std::str::from_utf8(&b[10..10 + hlen]).unwrap();
            assert!(
                header.contains("'descr': '|b1'") && header.contains("'shape': (34, 24, 13)"),
                "{header}"
            );
            let solid = b[10 + hlen..].iter().filter(|&&x| x == 1).count() as u64;
            assert_eq!(solid, j["solid_voxels"].as_u64().unwrap());
        }
    }
    // binvox: a cubic grid (--res with --pad), placement from translate and scale.
    let out = tmp("g.binvox");
    let o = gregvox(&[
        "voxelize",
        &input,
        "--res",
        "24",
        "--pad",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let back = gregvox::voxel::export::parse_binvox(&std::fs::read(&out).unwrap()).unwrap();
    let b = gregvox::voxel::grid::Bounds::of_triangles(
        &two_solids().positions,
        &two_solids().triangles,
    )
    .unwrap();
    let side = b.extent().iter().copied().fold(0.0, f64::max);
    let h = side / 24.0;
    assert_eq!(back.frame.dims, [26; 3]);
    for a in 0..3 {
        assert!((back.frame.origin[a] - (b.min[a] - h)).abs() <= 1e-6 * h);
        assert!((back.frame.voxel_size[a] - h).abs() <= 1e-6 * h);
    }
    // --npy-packed keeps the packed form.
    let out = tmp("p.npy");
    let o = gregvox(&[
        "voxelize",
        &input,
        "--dims",
        "30,20,9",
        "--npy-packed",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success());
    let b = std::fs::read(&out).unwrap();
    let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
    let header = std::str::from_utf8(&b[10..10 + hlen]).unwrap();
    assert!(
        header.contains("'descr': '|u1'") && header.contains("'shape': (30, 20, 2)"),
        "{header}"
    );
}

fn one_line_error(out: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "expected failure for '{needle}'");
    // Notes may precede the error; clap's argument errors add a usage hint after it.
    let errors: Vec<&str> = err
        .lines()
        .take_while(|l| !l.is_empty() && !l.starts_with("Usage:"))
        .filter(|l| !l.starts_with("gregvox voxelize: ") && !l.starts_with("  "))
        .collect();
    assert_eq!(
        errors.len(),
        1,
        "one error line expected for '{needle}':\n{err}"
    );
    assert!(errors[0].contains(needle), "'{needle}' not in: {err}");
    assert!(!err.contains("panicked"));
}

#[test]
fn bad_grid_flags_give_one_clear_error_and_write_nothing() {
    let spot = model_str("spot.obj");
    let out = tmp("bad.npy");
    let o = out.to_str().unwrap();
    for (args, needle) in [
        (vec!["--dims", "0,4,4"], "between 1 and 2048"),
        (vec!["--dims", "4,4"], "needs 3 comma-separated numbers"),
        (vec!["--dims", "4,x,4"], "cannot read 'x'"),
        (vec!["--voxel-size", "0"], "--voxel-size 0"),
        (vec!["--voxel-size", "NaN"], "--voxel-size NaN"),
        (vec!["--voxel-size", "1e-9"], "at most 2048 per axis"),
        (
            vec!["--res", "8", "--bbox", "0,0,0,1,1"],
            "needs 6 comma-separated numbers",
        ),
        (
            vec!["--res", "8", "--bbox", "0,0,0,-1,1,1"],
            "min corner must be below",
        ),
        (vec!["--res", "8", "--bbox", "0,0,0,inf,1,1"], "finite"),
        (vec!["--res", "2000", "--pad", "100"], "--pad 100"),
        (vec!["--res", "8", "--dims", "8,8,8"], "cannot be used with"),
        (vec![], "required arguments were not provided"),
    ] {
        let mut a = vec!["voxelize", spot.as_str()];
        a.extend(args.iter().copied());
        a.extend(["--out", o]);
        one_line_error(&gregvox(&a), needle);
        assert!(!out.exists(), "{args:?} wrote an output");
    }
    // binvox of a non-cubic grid, refused before voxelizing.
    let bv = tmp("bad.binvox");
    one_line_error(
        &gregvox(&[
            "voxelize",
            &spot,
            "--dims",
            "8,8,4",
            "--out",
            bv.to_str().unwrap(),
        ]),
        "binvox holds only cubic grids",
    );
    assert!(!bv.exists());
    // A flat mesh has no extent to divide.
    let flat = tmp("flat.obj");
    std::fs::write(&flat, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    one_line_error(
        &gregvox(&["voxelize", flat.to_str().unwrap(), "--dims", "4,4,4"]),
        "no extent along z",
    );
    // ... but a box makes it voxelizable, and --fill surface marks the triangle.
    let ok = gregvox(&[
        "voxelize",
        flat.to_str().unwrap(),
        "--dims",
        "4,4,4",
        "--bbox",
        "0,0,-0.5,1,1,0.5",
        "--fill",
        "surface",
        "--json",
    ]);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&ok.stdout).unwrap();
    assert!(j["solid_voxels"].as_u64().unwrap() >= 10, "{j}");
}

#[test]
fn an_empty_result_says_why() {
    // A sheet with no thickness encloses no centre: the solid is empty, and the report says so.
    let sheet = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
    let path = tmp("sheet.obj");
    std::fs::write(&path, sheet).unwrap();
    let out = gregvox(&[
        "voxelize",
        path.to_str().unwrap(),
        "--dims",
        "4,4,4",
        "--bbox",
        "0,0,-0.5,1,1,0.5",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no voxel is solid") && err.contains("--fill both"),
        "{err}"
    );
    let full = gregvox(&[
        "voxelize",
        path.to_str().unwrap(),
        "--dims",
        "4,4,4",
        "--bbox",
        "0,0,-0.5,1,1,0.5",
        "--fill",
        "both",
    ]);
    assert!(!String::from_utf8_lossy(&full.stderr).contains("no voxel"));
}
