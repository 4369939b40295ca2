//! Narrow-band level sets (`voxelize --what sdf`): on a box, every band value is the analytic signed
//! distance and every voxel closer than the half-width is active; on an open mesh the sign is the
//! voxelization's occupancy voxel for voxel; the .vdb file is written, laid out and refused as promised.
use glam::DVec3;
use gregvox::api::levelset::level_set;
use gregvox::api::{voxelize_on_cpu, Mesh, VoxelizeOptions};
use gregvox::voxel::levelset::LevelSet;

fn box_mesh(lo: f64, hi: f64) -> Mesh {
    let p: Vec<DVec3> = (0..8)
        .map(|i| {
            DVec3::new(
                if i & 1 == 1 { hi } else { lo },
                if i & 2 == 2 { hi } else { lo },
                if i & 4 == 4 { hi } else { lo },
            )
        })
        .collect();
    let faces = [
        vec![0, 2, 3, 1],
        vec![4, 5, 7, 6],
        vec![0, 1, 5, 4],
        vec![2, 6, 7, 3],
        vec![0, 4, 6, 2],
        vec![1, 3, 7, 5],
    ];
    Mesh::from_polygons(p, &faces).unwrap()
}

/// Every voxel's value (active or not) and activity, by walking the leaves; voxels outside every leaf
/// are ±background by the occupancy.
fn values(ls: &LevelSet) -> Vec<(f32, bool)> {
    let [nx, ny, nz] = ls.frame.dims;
    let at = |i: u32, j: u32, k: u32| ((i * ny + j) * nz + k) as usize;
    let mut v = vec![(0.0f32, false); (nx * ny * nz) as usize];
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                let s = if ls.solid_at(i, j, k) { -1.0 } else { 1.0 };
                v[at(i, j, k)] = (s * ls.background, false);
            }
        }
    }
    for leaf in &ls.leaves {
        for n in 0..512u32 {
            let (i, j, k) = (
                leaf.origin[0] + (n >> 6),
                leaf.origin[1] + (n >> 3 & 7),
                leaf.origin[2] + (n & 7),
            );
            if i < nx && j < ny && k < nz {
                let active = leaf.active[(n >> 6) as usize] >> (n & 63) & 1 == 1;
                v[at(i, j, k)] = (leaf.values[n as usize], active);
            }
        }
    }
    v
}

#[test]
fn on_a_box_every_band_value_is_the_analytic_distance_and_the_band_is_complete() {
    let mesh = box_mesh(0.0, 1.0);
    let opts = VoxelizeOptions::default().res(40).pad(6);
    let v = voxelize_on_cpu(&mesh, &opts).unwrap();
    for half_width in [1, 3, 5] {
        let ls = level_set(&mesh, &v.grid, half_width).unwrap();
        let h = v.grid.frame.voxel_size[0];
        assert!((ls.background as f64 - half_width as f64 * h).abs() < 1e-6 * h);
        let [nx, ny, nz] = v.grid.frame.dims;
        let all = values(&ls);
        let mut active = 0;
        for i in 0..nx {
            for j in 0..ny {
                for k in 0..nz {
                    let c = DVec3::from(v.grid.frame.centre(i, j, k));
                    // The signed distance to the unit box.
                    let q = (c - DVec3::splat(0.5)).abs() - DVec3::splat(0.5);
                    let sd = q.max(DVec3::ZERO).length() + q.max_element().min(0.0);
                    let (value, on) = all[((i * ny + j) * nz + k) as usize];
                    assert_eq!(value < 0.0, v.grid.get(i, j, k), "sign at {i},{j},{k}");
                    if sd.abs() < ls.background as f64 * (1.0 - 1e-6) {
                        assert!(
                            on,
                            "({i},{j},{k}) at {sd} is in the band of {}",
                            ls.background
                        );
                    }
                    if on {
                        active += 1;
                        assert!(
                            (value as f64 - sd).abs() <= 1e-6 * (1.0 + sd.abs()),
                            "{value} vs {sd}"
                        );
                    } else {
                        assert_eq!(value.abs(), ls.background);
                    }
                }
            }
        }
        assert_eq!(active, ls.active_count());
    }
}

#[test]
fn on_an_open_mesh_the_sign_is_the_voxelization_voxel_for_voxel() {
    let tri = gregvox::voxel::mesh::TriMesh::fan(
        &gregvox::mesh::load_mesh_file(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("assets/models/stanford-bunny.obj"),
        )
        .unwrap(),
    );
    // A third of the triangles removed: the solid's boundary leaves the surface across the holes.
    let open = gregvox::voxel::stress::with_holes(&tri, 1.0 / 3.0, 5);
    let faces: Vec<Vec<u32>> = open.triangles.iter().map(|t| t.to_vec()).collect();
    let mesh = Mesh::from_polygons(
        open.positions
            .iter()
            .map(|p| DVec3::from(p.map(f64::from)))
            .collect(),
        &faces,
    )
    .unwrap();
    let opts = VoxelizeOptions::default().res(48);
    let v = voxelize_on_cpu(&mesh, &opts).unwrap();
    let ls = level_set(&mesh, &v.grid, 2).unwrap();
    let [nx, ny, nz] = v.grid.frame.dims;
    let all = values(&ls);
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                let (value, _) = all[((i * ny + j) * nz + k) as usize];
                assert_eq!(value < 0.0, v.grid.get(i, j, k), "sign at {i},{j},{k}");
            }
        }
    }
    assert!(ls.active_count() > 0);
}

#[test]
fn the_cli_writes_a_level_set_vdb_and_refuses_other_outputs_and_bad_widths() {
    let dir = std::env::temp_dir().join(format!("gregvox-levelset-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bin = env!("CARGO_BIN_EXE_gregvox");
    let bunny =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/models/stanford-bunny.obj");
    let run = |extra: &[&str]| {
        std::process::Command::new(bin)
            .arg("voxelize")
            .arg(&bunny)
            .args(["--res", "32", "--method", "cpu", "--json"])
            .args(extra)
            .output()
            .unwrap()
    };
    let out = dir.join("ls.vdb");
    let o = run(&["--what", "sdf", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(
        j["level_set"]["active_voxels"].as_u64().unwrap() > 1000,
        "{j}"
    );
    let bytes = std::fs::read(&out).unwrap();
    assert_eq!(&bytes[..8], &0x5644_4220i64.to_le_bytes());
    let text = String::from_utf8_lossy(&bytes);
    assert!(text.contains("Tree_float_5_4_3") && text.contains("level set"));
    // The descriptor's end offset is the file's length.
    let at = bytes
        .windows(16)
        .position(|w| w == b"Tree_float_5_4_3")
        .unwrap()
        + 16
        + 4;
    let end = i64::from_le_bytes(bytes[at + 16..at + 24].try_into().unwrap());
    assert_eq!(end as usize, bytes.len());
    for (extra, needle) in [
        (vec!["--what", "sdf", "--out", "x.npy"], "give --out X.vdb"),
        (vec!["--what", "sdf"], "give --out X.vdb"),
        (
            vec!["--what", "sdf", "--half-width", "0", "--out", "y.vdb"],
            "--half-width 0",
        ),
        (
            vec!["--what", "sdf", "--fill", "surface", "--out", "y.vdb"],
            "--fill surface",
        ),
    ] {
        let o = run(&extra);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && err.contains(needle),
            "{extra:?}: {err}"
        );
    }
    assert!(!std::path::Path::new("y.vdb").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn one_huge_polygon_fanned_into_slivers_gets_the_distances_of_the_uncut_triangles() {
    // The attack on the distance tree: 3,000 slivers meeting at one corner, each crossing the grid.
    let n = 3000;
    let ring: Vec<DVec3> = (0..n)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            DVec3::new(a.cos(), a.sin(), 0.05 * (3.0 * a).sin())
        })
        .collect();
    let mesh = Mesh::from_polygons(ring, &[(0..n as u32).collect()]).unwrap();
    let v = voxelize_on_cpu(&mesh, &VoxelizeOptions::default().res(40).pad(4)).unwrap();
    let ls = level_set(&mesh, &v.grid, 3).unwrap();
    // Every active value against the plain query (a tree over the uncut fan).
    let mut points = Vec::new();
    let mut values = Vec::new();
    for leaf in &ls.leaves {
        for k in 0..512u32 {
            if leaf.active[(k >> 6) as usize] >> (k & 63) & 1 == 1 {
                let (i, j, z) = (
                    leaf.origin[0] + (k >> 6),
                    leaf.origin[1] + (k >> 3 & 7),
                    leaf.origin[2] + (k & 7),
                );
                points.push(v.grid.frame.centre(i, j, z));
                values.push(leaf.values[k as usize]);
            }
        }
    }
    assert!(points.len() > 1000, "{} active voxels", points.len());
    let plain = gregvox::api::query::unsigned_distance(&mesh, &points).unwrap();
    for (x, (&got, &want)) in values.iter().zip(&plain.distance).enumerate() {
        assert!(
            (got.abs() - want).abs() <= 1e-6 * (1.0 + want),
            "{:?}: {got} vs {want}",
            points[x]
        );
    }
}
