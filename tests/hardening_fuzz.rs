//! Structured random testing (proptest) of the parsers and builders: random and mutated OBJ text through
//! loading and `MeshMatrix`, jittered closed quad cages through the ACC-2 Gregory stencils, and random
//! triangle soups through the CPU voxelizer. Properties: nothing panics, and
//! - a loaded mesh satisfies the loader's invariants (finite positions; every face has ≥ 3 distinct,
//!   in-range vertices), and MeshMatrix's Euler characteristic equals V − E + F counted naively (referenced
//!   vertices, a hash set of undirected edges, faces);
//! - closed quad cages give G1 patches: positions agree across every shared edge within 1e-9 · the cage
//!   diagonal and normals within 1e-6 rad (surface_g1.rs's static bounds are 1e-12 and 1e-6; the gap bound is
//!   looser here because jitter makes cages with long thin faces, where f64 rounding grows);
//! - voxel grids have at most R³ solid voxels, all inside the grid: the count equals the number of (i, j, k)
//!   in [0, R)³ that read solid, so no bit outside the grid is set.
//!
//! Case counts keep the file well under 60 s in the test profile (1.6 s measured on 2 cores).
#[path = "surface_common.rs"]
mod common;

use glam::DVec3;
use gregvox::mesh::{parse_obj, Mesh, MeshMatrix};
use gregvox::surface::{GregoryStencils, Tangents};
use gregvox::voxel::cpu::{voxelize_cpu, FillRule};
use gregvox::voxel::grid::{Axis, GridFrame};
use gregvox::voxel::mesh::TriMesh;
use proptest::prelude::*;
use std::collections::HashSet;

/// The loader's invariants, and χ from MeshMatrix against a naive count.
fn check_mesh(mesh: &Mesh) {
    assert!(mesh.positions.iter().all(|p| p.is_finite()));
    assert!(mesh.n_faces() > 0);
    let mut edges = HashSet::new();
    let mut referenced = HashSet::new();
    for f in 0..mesh.n_faces() {
        let face = mesh.face(f);
        assert!(face.len() >= 3);
        let distinct: HashSet<u32> = face.iter().copied().collect();
        assert_eq!(distinct.len(), face.len(), "repeated vertex in face {f}");
        for (k, &v) in face.iter().enumerate() {
            assert!((v as usize) < mesh.positions.len());
            let w = face[(k + 1) % face.len()];
            edges.insert((v.min(w), v.max(w)));
            referenced.insert(v);
        }
    }
    let naive = referenced.len() as i64 - edges.len() as i64 + mesh.n_faces() as i64;
    let m = MeshMatrix::from_mesh(mesh);
    let report = m.report();
    assert_eq!(report.euler_characteristic, naive);
    assert_eq!(report.edges, edges.len());
}

/// One OBJ line from a grammar that mixes valid statements with the ways files go wrong.
fn obj_line() -> impl Strategy<Value = String> {
    let coord = prop_oneof![
        6 => (-100.0f64..100.0).prop_map(|x| format!("{x}")),
        1 => Just("nan".to_string()),
        1 => Just("-inf".to_string()),
        1 => Just("1e309".to_string()),
        1 => Just("-0".to_string()),
        1 => Just("x1".to_string()),
        1 => Just(String::new()),
    ];
    let index = prop_oneof![
        8 => (1i64..12).prop_map(|i| i.to_string()),
        1 => (-12i64..0).prop_map(|i| i.to_string()),
        1 => Just("0".to_string()),
        1 => Just("99999999999".to_string()),
        1 => (1i64..12).prop_map(|i| format!("{i}/{i}/{i}")),
        1 => (1i64..12).prop_map(|i| format!("{i}//{i}")),
        1 => Just("a".to_string()),
    ];
    prop_oneof![
        5 => proptest::collection::vec(coord, 0..5).prop_map(|c| format!("v {}", c.join(" "))),
        4 => proptest::collection::vec(index, 0..7).prop_map(|i| format!("f {}", i.join(" "))),
        1 => Just("# a comment".to_string()),
        1 => Just("vn 0 0 1".to_string()),
        1 => Just("o name".to_string()),
        1 => "[ -~]{0,20}",
    ]
}

/// A valid closed quad cage as OBJ text: the demo's lattice box.
fn box_obj(nx: u32, ny: u32, nz: u32) -> String {
    let m = gregvox::engine::cage::builtin_cage(nx, ny, nz);
    let mut s = String::new();
    for p in &m.positions {
        s.push_str(&format!("v {} {} {}\n", p.x, p.y, p.z));
    }
    for f in 0..m.n_faces() {
        let idx: Vec<String> = m.face(f).iter().map(|v| (v + 1).to_string()).collect();
        s.push_str(&format!("f {}\n", idx.join(" ")));
    }
    s
}

/// A byte-level edit of a text.
#[derive(Debug, Clone)]
enum Mutation {
    Delete(usize, usize),
    Insert(usize, Vec<u8>),
    Flip(usize, u8),
    DuplicateLine(usize),
    SwapLines(usize, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 1usize..20).prop_map(|(a, n)| Mutation::Delete(a, n)),
        (any::<usize>(), proptest::collection::vec(any::<u8>(), 1..8))
            .prop_map(|(a, b)| Mutation::Insert(a, b)),
        (any::<usize>(), any::<u8>()).prop_map(|(a, b)| Mutation::Flip(a, b)),
        any::<usize>().prop_map(Mutation::DuplicateLine),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::SwapLines(a, b)),
    ]
}

fn apply(text: &str, muts: &[Mutation]) -> Vec<u8> {
    let mut b = text.as_bytes().to_vec();
    for m in muts {
        let n = b.len().max(1);
        match m {
            Mutation::Delete(a, k) => {
                let a = a % n;
                let e = (a + k).min(b.len());
                if a < e {
                    b.drain(a..e);
                }
            }
            Mutation::Insert(a, bytes) => {
                let a = a % (b.len() + 1);
                b.splice(a..a, bytes.iter().copied());
            }
            Mutation::Flip(a, x) => {
                if !b.is_empty() {
                    let a = a % b.len();
                    b[a] = *x;
                }
            }
            Mutation::DuplicateLine(a) | Mutation::SwapLines(a, _) => {
                let mut lines: Vec<Vec<u8>> =
                    b.split(|&c| c == b'\n').map(<[u8]>::to_vec).collect();
                let l = lines.len();
                let i = a % l;
                if let Mutation::SwapLines(_, c) = m {
                    lines.swap(i, c % l);
                } else {
                    let dup = lines[i].clone();
                    lines.insert(i, dup);
                }
                b = lines.join(&b'\n');
            }
        }
    }
    b
}

/// Loading from bytes the way the CLI does (through a file, so the byte-level checks run too).
fn load_bytes(bytes: &[u8]) -> gregvox::Result<Mesh> {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static N: AtomicUsize = AtomicUsize::new(0);
    let path = std::env::temp_dir().join(format!(
        "gregvox-fuzz-{}-{}.obj",
        std::process::id(),
        N.fetch_add(1, Ordering::SeqCst)
    ));
    std::fs::write(&path, bytes).unwrap();
    let r = gregvox::mesh::load_obj(&path);
    std::fs::remove_file(&path).unwrap();
    r
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1024, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn random_obj_text_loads_or_is_refused_with_a_line(lines in proptest::collection::vec(obj_line(), 0..40)) {
        let text = lines.join("\n");
        match parse_obj(&text, "random.obj") {
            Ok(mesh) => check_mesh(&mesh),
            Err(e) => {
                let msg = e.to_string();
                prop_assert!(msg.starts_with("random.obj: "), "{msg}");
                prop_assert!(!msg.contains('\n'), "one line: {msg}");
            }
        }
    }

    #[test]
    fn mutated_obj_files_load_or_are_refused(
        n in (1u32..4, 1u32..3, 1u32..3),
        muts in proptest::collection::vec(mutation(), 1..6),
    ) {
        let bytes = apply(&box_obj(n.0, n.1, n.2), &muts);
        match load_bytes(&bytes) {
            Ok(mesh) => {
                check_mesh(&mesh);
                // Whatever survived must also go through the Gregory builder without a panic.
                let _ = GregoryStencils::new(&MeshMatrix::from_mesh(&mesh), Tangents::OpenSubdiv);
            }
            Err(e) => prop_assert!(e.to_string().contains("gregvox-fuzz-"), "{e}"),
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn jittered_closed_quad_cages_give_g1_gregory_patches(
        n in (1u32..4, 1u32..3, 1u32..3),
        jitter in proptest::collection::vec((-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0), 64),
        rotate in proptest::collection::vec(0usize..4, 64),
        shuffle_seed in any::<u64>(),
    ) {
        let base = gregvox::engine::cage::builtin_cage(n.0, n.1, n.2);
        // Jitter each vertex by up to 15 % of the smallest lattice step (faces stay non-degenerate).
        let step = [2.0 / n.0 as f64, 1.0 / n.1 as f64, 1.0 / n.2 as f64]
            .into_iter()
            .fold(f64::INFINITY, f64::min);
        let positions: Vec<DVec3> = base
            .positions
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let j = jitter[i % jitter.len()];
                *p + 0.15 * step * DVec3::new(j.0, j.1, j.2)
            })
            .collect();
        // Renumber the vertices and rotate each face's start: neither may change the surface's smoothness.
        let nv = positions.len();
        let mut order: Vec<usize> = (0..nv).collect();
        let mut x = shuffle_seed | 1;
        for i in (1..nv).rev() {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            order.swap(i, (x % (i as u64 + 1)) as usize);
        }
        let mut new_id = vec![0u32; nv];
        for (new, &old) in order.iter().enumerate() {
            new_id[old] = new as u32;
        }
        let shuffled: Vec<DVec3> = order.iter().map(|&old| positions[old]).collect();
        let faces: Vec<Vec<u32>> = (0..base.n_faces())
            .map(|f| {
                let q = base.face(f);
                let r = rotate[f % rotate.len()];
                (0..4).map(|k| new_id[q[(k + r) % 4] as usize]).collect()
            })
            .collect();
        let mesh = Mesh::from_polygons(shuffled, &faces).unwrap();
        check_mesh(&mesh);
        let stencils = GregoryStencils::new(&MeshMatrix::from_mesh(&mesh), Tangents::OpenSubdiv).unwrap();
        let patches = stencils.patches_f64(&mesh.positions).unwrap();
        let g = common::g1_figures(&mesh, &patches, 9);
        let d = common::diag(&mesh.positions);
        prop_assert_eq!(g.edges, 2 * mesh.n_faces(), "closed quad mesh: every edge interior");
        prop_assert!(g.gap <= 1e-9 * d, "gap {:e}·diag", g.gap / d);
        prop_assert!(g.jump <= 1e-6, "normal jump {:e} rad", g.jump);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn cpu_voxel_grids_stay_inside_the_grid(
        points in proptest::collection::vec(
            prop_oneof![
                8 => (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0),
                1 => Just((0.0f32, 0.0, 0.0)),
                1 => (-1e-7f32..1e-7, -1.0f32..1.0, 0.0f32..1e-7),
            ],
            3..30,
        ),
        tris in proptest::collection::vec((any::<u32>(), any::<u32>(), any::<u32>()), 1..40),
        res in 1u32..20,
        axis in 0usize..3,
        parity in any::<bool>(),
    ) {
        let positions: Vec<[f32; 3]> = points.iter().map(|p| [p.0, p.1, p.2]).collect();
        let n = positions.len() as u32;
        let soup = TriMesh {
            triangles: tris.iter().map(|t| [t.0 % n, t.1 % n, t.2 % n]).collect(),
            positions,
        };
        let (tri, _report) = soup.clean();
        let Ok(frame) = GridFrame::from_points(&tri.positions, res) else {
            // Only a single-point box is refused (the points are finite and non-empty).
            let first = tri.positions[0];
            prop_assert!(tri.positions.iter().all(|p| *p == first));
            return Ok(());
        };
        let rule = if parity { FillRule::Parity } else { FillRule::Winding };
        let grid = voxelize_cpu(&tri, &frame, Axis::from_index(axis), rule);
        prop_assert_eq!(grid.frame.dims, [res; 3]);
        prop_assert_eq!(grid.words.len() as u64 * 4, gregvox::voxel::grid::VoxelGrid::bytes_for(&frame, Axis::from_index(axis)));
        let r = res as u64;
        let count = grid.count();
        prop_assert!(count <= r * r * r);
        let mut inside = 0u64;
        for i in 0..res {
            for j in 0..res {
                for k in 0..res {
                    inside += grid.get(i, j, k) as u64;
                }
            }
        }
        prop_assert_eq!(count, inside, "solid bits outside [0, R)³");
    }
}
