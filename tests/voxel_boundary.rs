//! The solid's boundary mesh (`voxel::boundary`): closed, manifold and outward on every grid, including
//! every 2×2×2 configuration, noise and checkerboards; its own voxelization at the same grid is the grid;
//! the CLI writes it as .obj/.stl/.glb/.ply; a noise grid past the quad limit is refused.
use gregvox::api::topology;
use gregvox::mesh::Mesh;
use gregvox::voxel::boundary::{boundary_mesh, MAX_BOUNDARY_QUADS};
use gregvox::voxel::cpu::{voxelize_cpu, FillRule};
use gregvox::voxel::grid::{Axis, GridFrame, VoxelGrid};
use gregvox::voxel::mesh::TriMesh;
use std::collections::HashSet;

/// Deterministic noise (SplitMix64).
fn noise(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = s;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Checks the boundary mesh of `grid` against every promise and returns it.
fn check(grid: &VoxelGrid, what: &str) -> Mesh {
    let mesh = boundary_mesh(grid).unwrap_or_else(|e| panic!("{what}: {e}"));
    if grid.count() == 0 {
        assert_eq!(mesh.n_faces(), 0, "{what}: an empty grid has no boundary");
        return mesh;
    }
    let r = topology(&mesh);
    assert!(r.closed, "{what}: {r:?}");
    assert_eq!(r.non_manifold_edges, 0, "{what}");
    assert_eq!(r.non_manifold_vertices, 0, "{what}");
    assert!(r.consistently_oriented, "{what}");
    assert_eq!(r.unreferenced_vertices, 0, "{what}");
    // Fanned from their first corners (as STL/GLB and most OBJ readers do), the polygons stay manifold.
    let t = topology(&mesh.triangulated());
    assert!(
        t.closed
            && t.non_manifold_edges == 0
            && t.non_manifold_vertices == 0
            && t.consistently_oriented,
        "{what}: triangulated {t:?}"
    );
    let distinct: HashSet<[u64; 3]> = mesh
        .positions
        .iter()
        .map(|p| p.to_array().map(f64::to_bits))
        .collect();
    assert_eq!(
        distinct.len(),
        mesh.positions.len(),
        "{what}: coincident vertices"
    );
    // Outward: the enclosed volume is the solid voxels' (split corners move by 1/64 voxel at most).
    let mut volume = 0.0;
    for f in 0..mesh.n_faces() {
        let c = mesh.face(f);
        let p = |i: usize| mesh.positions[c[i] as usize];
        for t in 1..c.len() - 1 {
            volume += p(0).dot(p(t).cross(p(t + 1))) / 6.0;
        }
    }
    let cell: f64 = grid.frame.voxel_size.iter().product();
    let expected = grid.count() as f64 * cell;
    assert!(
        (volume - expected).abs() <= 0.05 * cell * (1.0 + mesh.positions.len() as f64 / 8.0),
        "{what}: volume {volume} for {} voxels of {cell}",
        grid.count()
    );
    // Its own voxelization at the same grid is the grid.
    let tri = TriMesh::fan(&mesh);
    let back = voxelize_cpu(&tri, &grid.frame, Axis::Z, FillRule::Winding);
    assert_eq!(
        back.count_differences(&grid.to_axis(Axis::Z)),
        0,
        "{what}: the boundary voxelizes to another grid"
    );
    mesh
}

#[test]
fn every_two_by_two_by_two_configuration_gives_a_closed_manifold_outward_mesh_of_the_same_voxels() {
    for config in 0u32..256 {
        let mut g = VoxelGrid::empty(GridFrame::cubic(4, [0.0; 3], 4.0), Axis::Z);
        for b in 0..8 {
            if config >> b & 1 == 1 {
                g.set(1 + (b & 1), 1 + (b >> 1 & 1), 1 + (b >> 2 & 1), true);
            }
        }
        check(&g, &format!("configuration {config:08b}"));
    }
}

#[test]
fn random_grids_of_every_density_and_layout_give_manifold_meshes_of_the_same_voxels() {
    let mut rnd = noise(7);
    // z spans 1, 31, 32, 33 and 70 voxels: single, full and straddling words.
    for (n, dims) in [[5, 4, 1], [6, 5, 31], [3, 7, 32], [4, 4, 33], [6, 3, 70]]
        .into_iter()
        .enumerate()
    {
        for density in [0.05, 0.3, 0.5, 0.7, 0.95] {
            for axis in Axis::ALL {
                let frame = GridFrame {
                    dims,
                    origin: [-1.5, 0.25, 3.0],
                    voxel_size: [0.5, 1.25, 0.75],
                };
                let mut g = VoxelGrid::empty(frame, axis);
                for i in 0..dims[0] {
                    for j in 0..dims[1] {
                        for k in 0..dims[2] {
                            g.set(i, j, k, rnd() < density);
                        }
                    }
                }
                check(
                    &g,
                    &format!("grid {n} {dims:?}, density {density}, bits along {axis:?}"),
                );
            }
        }
    }
}

#[test]
fn a_checkerboard_splits_every_corner_into_separate_cubes() {
    let mut g = VoxelGrid::empty(GridFrame::cubic(6, [0.0; 3], 1.0), Axis::Z);
    for i in 0..6 {
        for j in 0..6 {
            for k in 0..6 {
                g.set(i, j, k, (i + j + k) % 2 == 0);
            }
        }
    }
    let m = check(&g, "checkerboard");
    let r = topology(&m);
    // 108 cubes, each its own sphere.
    assert_eq!((r.components, m.n_faces()), (108, 6 * 108));
    assert_eq!(r.euler_characteristic, 2 * 108);
    // Every lattice edge inside is pinched: each of its two cubes gets its own midpoint on it.
    assert!(m.positions.len() > 8 * 108);
}

#[test]
fn a_ball_is_one_sphere_and_a_ring_one_torus() {
    let n = 40u32;
    let mut ball = VoxelGrid::empty(GridFrame::cubic(n, [0.0; 3], 1.0), Axis::X);
    let mut ring = VoxelGrid::empty(GridFrame::cubic(n, [0.0; 3], 1.0), Axis::Z);
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let p = [i, j, k].map(|c| c as f64 + 0.5 - n as f64 / 2.0);
                let r2 = p.iter().map(|x| x * x).sum::<f64>();
                ball.set(i, j, k, r2 < 18.0 * 18.0);
                let rho = (p[0] * p[0] + p[1] * p[1]).sqrt();
                ring.set(i, j, k, (rho - 12.0).powi(2) + p[2] * p[2] < 5.0 * 5.0);
            }
        }
    }
    let r = topology(&check(&ball, "ball"));
    assert_eq!((r.components, r.genus), (1, Some(0)));
    let r = topology(&check(&ring, "ring"));
    assert_eq!((r.components, r.genus), (1, Some(1)));
}

#[test]
fn a_noise_grid_past_the_quad_limit_is_refused_before_any_mesh_is_built() {
    // A 512³ checkerboard exposes all six faces of half its voxels: 3·512³ > the limit.
    let n = 512u32;
    let mut g = VoxelGrid::empty(GridFrame::cubic(n, [0.0; 3], 1.0), Axis::Z);
    let w = g.frame.words_per_column(Axis::Z) as usize;
    for j in 0..n as usize {
        for i in 0..n as usize {
            let word = if (i + j) % 2 == 0 {
                0x5555_5555
            } else {
                0xAAAA_AAAA
            };
            g.words[(j * n as usize + i) * w..][..w].fill(word);
        }
    }
    assert!(3 * (n as u64).pow(3) > MAX_BOUNDARY_QUADS);
    let e = boundary_mesh(&g).unwrap_err().to_string();
    assert!(
        e.contains(&format!("{} voxel faces", 3 * (n as u64).pow(3))),
        "{e}"
    );
}

#[test]
fn voxelize_writes_the_boundary_mesh_for_mesh_extensions_and_ply_with_the_flag() {
    let dir = std::env::temp_dir().join(format!("gregvox-boundary-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bin = env!("CARGO_BIN_EXE_gregvox");
    let voxelize = |extra: &[&std::ffi::OsStr]| {
        let o = std::process::Command::new(bin)
            .args(["voxelize", "assets/models/stanford-bunny.obj"])
            .args(["--res", "24", "--method", "cpu"])
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        o
    };
    let run = |out: &std::path::Path, extra: &[&str]| {
        let mut args = vec!["--out".as_ref(), out.as_os_str()];
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        voxelize(&args);
    };
    let solid = {
        let o = voxelize(&["--json".as_ref()]);
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        j["solid_voxels"].as_u64().unwrap()
    };
    for (name, extra) in [
        ("b.obj", &[][..]),
        ("b.ply", &["--ply-boundary"][..]),
        ("b.glb", &[][..]),
        ("b.stl", &[][..]),
    ] {
        let path = dir.join(name);
        run(&path, extra);
        let mesh = gregvox::mesh::load_mesh_file(&path).unwrap();
        let r = topology(&mesh);
        assert!(
            r.closed && r.non_manifold_edges == 0 && r.consistently_oriented,
            "{name}: {r:?}"
        );
        // Every face of the solid's surface, as one quad or two triangles.
        let quads = if name.ends_with(".obj") || name.ends_with(".ply") {
            mesh.n_faces()
        } else {
            mesh.n_faces() / 2
        };
        assert!(
            quads >= 6 * (solid as f64).powf(2.0 / 3.0) as usize,
            "{name}: {quads} quads"
        );
    }
    // Without the flag .ply stays the voxel centres: a point cloud, no faces.
    let centres = dir.join("c.ply");
    run(&centres, &[]);
    let head = std::fs::read(&centres).unwrap();
    let text = String::from_utf8_lossy(&head[..200.min(head.len())]).to_string();
    assert!(text.contains(&format!("element vertex {solid}")), "{text}");
    assert!(!text.contains("element face"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}
