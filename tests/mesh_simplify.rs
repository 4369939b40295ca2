//! `simplify`: the guarantees of the issue (no flips, manifold in → manifold out, closed stays closed,
//! Euler characteristic and pieces kept, borders and seams untouched), the targets (ratio, faces, error),
//! determinism across thread counts, levels of detail, and the distance to the input.
mod mesh_common;
use glam::DVec3;
use gregvox::api::{simplify, simplify_lod, topology, Placement, SimplifyOptions};
use gregvox::mesh::distance::{DistanceTree, Stack};
use gregvox::mesh::{load_obj, Mesh, MeshMatrix};
use mesh_common::model;

/// A test model, fan-triangulated as `simplify` triangulates it (topology is compared on triangles:
/// fanning two quads that share three vertices can itself make a non-manifold edge, as in suzanne).
fn load(name: &str) -> Mesh {
    load_obj(model(&format!("{name}.obj")))
        .unwrap()
        .triangulated()
}

fn tris(m: &Mesh) -> Vec<[[f64; 3]; 3]> {
    let mut out = Vec::new();
    for f in 0..m.n_faces() {
        let face = m.face(f);
        for k in 1..face.len() - 1 {
            out.push([face[0], face[k], face[k + 1]].map(|v| m.positions[v as usize].to_array()));
        }
    }
    out
}

fn normal(t: &[[f64; 3]; 3]) -> DVec3 {
    let p = t.map(DVec3::from_array);
    (p[1] - p[0]).cross(p[2] - p[0])
}

/// Samples of a mesh: its referenced vertices and its triangles' centroids.
fn samples(m: &Mesh) -> Vec<[f64; 3]> {
    let mut used = vec![false; m.positions.len()];
    for &v in &m.indices {
        used[v as usize] = true;
    }
    let mut s: Vec<[f64; 3]> = (0..m.positions.len())
        .filter(|&v| used[v])
        .map(|v| m.positions[v].to_array())
        .collect();
    for t in tris(m) {
        let c = (DVec3::from_array(t[0]) + DVec3::from_array(t[1]) + DVec3::from_array(t[2])) / 3.0;
        s.push(c.to_array());
    }
    s
}

/// Symmetric Hausdorff and mean distance over both meshes' samples (vertices and centroids), as
/// fractions of the input's diagonal.
fn distances(a: &Mesh, b: &Mesh) -> (f64, f64) {
    let one_way = |from: &Mesh, to: &Mesh| {
        let tree = DistanceTree::new(&tris(to));
        let mut stack = Stack::default();
        let d: Vec<f64> = samples(from)
            .iter()
            .map(|&p| tree.closest(p, &mut stack).unwrap().distance2.sqrt())
            .collect();
        (
            d.iter().copied().fold(0.0f64, f64::max),
            d.iter().sum::<f64>(),
            d.len(),
        )
    };
    let (lo, hi) = a.positions.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let diag = (hi - lo).length();
    let (m1, s1, n1) = one_way(a, b);
    let (m2, s2, n2) = one_way(b, a);
    (m1.max(m2) / diag, (s1 + s2) / (n1 + n2) as f64 / diag)
}

/// Output triangles that face against the input surface they stand on: the nearest input triangle to
/// the centroid faces the other way, and so does the area-weighted normal of the input triangles whose
/// centroids lie within the output triangle's circumradius (cosine below −0.1). The second test keeps
/// the proxy honest where the nearest triangle alone is the wrong side of a thin part or a crease.
fn flipped(input: &Mesh, output: &Mesh) -> usize {
    let it = tris(input);
    let tree = DistanceTree::new(&it);
    let centroid = |t: &[[f64; 3]; 3]| {
        (DVec3::from_array(t[0]) + DVec3::from_array(t[1]) + DVec3::from_array(t[2])) / 3.0
    };
    let mut stack = Stack::default();
    tris(output)
        .iter()
        .filter(|t| {
            let c = centroid(t);
            let near = tree.closest(c.to_array(), &mut stack).unwrap();
            let n = normal(t);
            if n.dot(normal(&it[near.triangle as usize])) >= 0.0 {
                return false;
            }
            let r = t
                .iter()
                .map(|&p| DVec3::from_array(p).distance(c))
                .fold(0.0, f64::max);
            let around: DVec3 = it
                .iter()
                .filter(|u| centroid(u).distance(c) <= r)
                .map(normal)
                .sum::<DVec3>()
                + normal(&it[near.triangle as usize]);
            n.normalize().dot(around.normalize()) < -0.1
        })
        .count()
}

/// The topology guarantees between an input and its reduction.
fn assert_topology_kept(name: &str, input: &Mesh, output: &Mesh) {
    let (a, b) = (topology(input), topology(output));
    assert_eq!(
        b.non_manifold_edges, a.non_manifold_edges,
        "{name}: non-manifold edges"
    );
    assert!(
        b.non_manifold_vertices <= a.non_manifold_vertices,
        "{name}: non-manifold vertices"
    );
    assert_eq!(
        b.inconsistent_edges, a.inconsistent_edges,
        "{name}: orientation"
    );
    assert_eq!(b.closed, a.closed, "{name}: closed");
    assert_eq!(
        b.euler_characteristic, a.euler_characteristic,
        "{name}: Euler characteristic"
    );
    assert_eq!(b.face_components, a.face_components, "{name}: pieces");
    // Loops are followed wedge by wedge, so loops that touch at a pinched vertex count apart; the
    // count is defined where every edge is manifold and consistently oriented.
    if a.non_manifold_edges == 0 && a.inconsistent_edges == 0 {
        assert_eq!(b.boundary_loops, a.boundary_loops, "{name}: boundary loops");
    }
}

fn of_trimesh(t: &gregvox::voxel::mesh::TriMesh) -> Mesh {
    let p = t
        .positions
        .iter()
        .map(|p| DVec3::from(p.map(f64::from)))
        .collect();
    let f: Vec<Vec<u32>> = t.triangles.iter().map(|t| t.to_vec()).collect();
    Mesh::from_polygons(p, &f).unwrap()
}

fn reduce(m: &Mesh, opts: SimplifyOptions) -> gregvox::api::SimplifiedMesh {
    simplify(m, &opts).unwrap()
}

fn ratio(r: f64) -> SimplifyOptions {
    SimplifyOptions {
        ratio: Some(r),
        ..Default::default()
    }
}

/// Boundary vertices of a mesh (by id), sorted: its boundary loops' vertices.
fn boundary_vertices(m: &Mesh) -> Vec<u32> {
    let mut v: Vec<u32> = MeshMatrix::from_mesh(m).boundary_loops().concat();
    v.sort_unstable();
    v.dedup();
    v
}

#[test]
fn reductions_of_the_test_models_keep_topology_and_flip_nothing() {
    let (mut mean_keep, mut mean_optimal) = (0.0, 0.0);
    for name in ["stanford-bunny", "spot", "cow", "teapot", "suzanne"] {
        let input = load(name);
        for r in [0.5, 0.1, 0.01] {
            for placement in [Placement::Keep, Placement::Optimal] {
                let out = reduce(
                    &input,
                    SimplifyOptions {
                        ratio: Some(r),
                        placement,
                        ..Default::default()
                    },
                );
                let flips = flipped(&input, &out.mesh);
                let (h, mean) = distances(&input, &out.mesh);
                eprintln!(
                    "{name} {r} {placement:?}: {} → {} faces, {} passes, error {:.2e}, hausdorff {:.3} %, mean {:.4} %, flips {flips}",
                    out.report.input_faces, out.report.faces, out.report.passes, out.report.relative_error, 100.0 * h, 100.0 * mean
                );
                assert_topology_kept(name, &input, &out.mesh);
                // The nearest input triangle is a proxy for "the surface there": on the smooth closed
                // models it is exact enough to demand none; thin parts and interpenetrating shells
                // (teapot, cow's horns, suzanne's eyes) make it pick the other side now and then.
                if matches!(name, "stanford-bunny" | "spot") && r >= 0.1 {
                    assert_eq!(flips, 0, "{name} {r} {placement:?}: flipped triangles");
                } else if r >= 0.1 {
                    // (At 1 % suzanne is a 22-triangle blob: no proxy of "the surface there" holds.)
                    assert!(
                        flips * 20 <= out.report.faces.max(20),
                        "{name} {r} {placement:?}: {flips} flipped"
                    );
                }
                if r >= 0.1 {
                    // A sanity bound (a broken reduction is off by tens of %): suzanne at 10 % is 96
                    // triangles, whose worst point moves between 4 and 6.5 % with the tie-breaks.
                    assert!(h < 0.07, "{name} {r} {placement:?}: Hausdorff {h}");
                }
                // (At 1 % the two placements stop at different counts on the small models.)
                match placement {
                    Placement::Keep if r >= 0.1 => mean_keep += mean,
                    Placement::Optimal if r >= 0.1 => mean_optimal += mean,
                    _ => {}
                }
            }
        }
    }
    eprintln!("mean distance summed: keep {mean_keep:.5}, optimal {mean_optimal:.5}");
    assert!(
        mean_optimal < 0.9 * mean_keep,
        "optimal placement must lower the mean distance"
    );
}

#[test]
fn the_face_target_is_met_and_the_error_target_bounds_the_error() {
    let input = load("stanford-bunny");
    for faces in [50_000, 10_000, 1_000, 100] {
        let out = reduce(
            &input,
            SimplifyOptions {
                faces: Some(faces),
                ..Default::default()
            },
        );
        assert!(
            out.report.faces <= faces && out.report.faces + 2 >= faces,
            "{faces}: {}",
            out.report.faces
        );
        assert_eq!(out.mesh.n_faces(), out.report.faces);
    }
    let mut last = usize::MAX;
    for e in [1e-4, 1e-3, 1e-2] {
        let out = reduce(
            &input,
            SimplifyOptions {
                error: Some(e),
                ..Default::default()
            },
        );
        assert!(
            out.report.relative_error <= e,
            "{e}: {}",
            out.report.relative_error
        );
        assert!(
            out.report.faces < last,
            "a larger error bound reduces further"
        );
        last = out.report.faces;
        // The bound is on quadric errors (distances to the planes each vertex stands for): the surface
        // stays within a few times it.
        let (h, _) = distances(&input, &out.mesh);
        assert!(h <= 10.0 * e + 1e-4, "{e}: Hausdorff {h}");
    }
    // Both targets: the first reached stops.
    let both = reduce(
        &input,
        SimplifyOptions {
            ratio: Some(0.01),
            error: Some(1e-4),
            ..Default::default()
        },
    );
    assert!(both.report.faces > 694 && both.report.relative_error <= 1e-4);
}

#[test]
fn closed_meshes_stay_closed_down_to_the_smallest_of_their_topology() {
    let torus = of_trimesh(&gregvox::voxel::mesh::TriMesh::torus(
        [0.0; 3], 1.0, 0.3, 48, 24,
    ));
    let sphere = of_trimesh(&gregvox::voxel::mesh::TriMesh::sphere(
        [0.0; 3], 1.0, 24, 48, false,
    ));
    for (name, m, genus) in [("torus", &torus, 1), ("sphere", &sphere, 0)] {
        let out = reduce(
            m,
            SimplifyOptions {
                faces: Some(0),
                ..Default::default()
            },
        );
        let t = topology(&out.mesh);
        assert!(
            t.closed && t.non_manifold_edges == 0 && t.non_manifold_vertices == 0,
            "{name}: {t:?}"
        );
        assert_eq!(t.genus, Some(genus), "{name}");
        assert!(
            out.report.faces <= if genus == 0 { 4 } else { 64 },
            "{name}: {} faces left",
            out.report.faces
        );
    }
    // A tetrahedron and a lone triangle are as small as closed and open pieces get.
    let tet = Mesh::from_polygons(
        vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
        &[vec![0, 2, 1], vec![0, 1, 3], vec![1, 2, 3], vec![0, 3, 2]],
    )
    .unwrap();
    assert_eq!(
        reduce(
            &tet,
            SimplifyOptions {
                faces: Some(0),
                ..Default::default()
            }
        )
        .report
        .faces,
        4
    );
    let tri = Mesh::from_polygons(vec![DVec3::ZERO, DVec3::X, DVec3::Y], &[vec![0, 1, 2]]).unwrap();
    assert_eq!(
        reduce(
            &tri,
            SimplifyOptions {
                faces: Some(0),
                ..Default::default()
            }
        )
        .report
        .faces,
        1
    );
}

#[test]
fn borders_stay_on_their_vertices_and_lock_border_keeps_every_one() {
    let input = load("stanford-bunny");
    let border: Vec<DVec3> = boundary_vertices(&input)
        .iter()
        .map(|&v| input.positions[v as usize])
        .collect();
    assert_eq!(border.len(), 223);
    let free = reduce(&input, ratio(0.05));
    let locked = reduce(
        &input,
        SimplifyOptions {
            ratio: Some(0.05),
            lock_border: true,
            ..Default::default()
        },
    );
    for (what, out) in [("free", &free), ("locked", &locked)] {
        // Every output boundary vertex is an input boundary vertex, unmoved.
        for v in boundary_vertices(&out.mesh) {
            let p = out.mesh.positions[v as usize];
            assert!(
                border.contains(&p),
                "{what}: boundary vertex {v} at {p} moved"
            );
        }
        assert_topology_kept(what, &input, &out.mesh);
    }
    let kept: Vec<DVec3> = boundary_vertices(&locked.mesh)
        .iter()
        .map(|&v| locked.mesh.positions[v as usize])
        .collect();
    assert_eq!(
        kept.len(),
        border.len(),
        "lock_border keeps every boundary vertex"
    );
    assert!(
        boundary_vertices(&free.mesh).len() < border.len(),
        "without the lock the border is reduced"
    );
}

#[test]
fn attribute_seams_reduce_without_tearing_and_non_manifold_parts_are_untouched() {
    // A sphere cut along a meridian into a mesh whose seam vertices are duplicated (as a UV seam is
    // written): two vertex ids at one position along the cut.
    let s = gregvox::voxel::mesh::TriMesh::sphere([0.0; 3], 1.0, 24, 48, false);
    let mut positions: Vec<DVec3> = s
        .positions
        .iter()
        .map(|p| DVec3::from(p.map(f64::from)))
        .collect();
    let on_seam = |p: DVec3| p.y.abs() < 1e-6 && p.x > 1e-6;
    let mut twin = std::collections::HashMap::new();
    let n = positions.len();
    for v in 0..n {
        if on_seam(positions[v]) {
            twin.insert(v as u32, positions.len() as u32);
            positions.push(positions[v]);
        }
    }
    // Triangles on the y < 0 side of the cut use the twins.
    let faces: Vec<Vec<u32>> = s
        .triangles
        .iter()
        .map(|t| {
            let c: DVec3 = t.iter().map(|&v| positions[v as usize]).sum::<DVec3>() / 3.0;
            t.iter()
                .map(|&v| {
                    if c.y < 0.0 {
                        *twin.get(&v).unwrap_or(&v)
                    } else {
                        v
                    }
                })
                .collect()
        })
        .collect();
    let seamed = Mesh::from_polygons(positions.clone(), &faces).unwrap();
    let out = reduce(&seamed, ratio(0.1));
    // The seam reduces, both sides together, and stays closed: every boundary edge of the output (the
    // sphere has no other boundary) has a twin at the same two positions the other way round, and no
    // seam vertex moved.
    assert!(
        out.report.faces <= seamed.n_faces() / 10 + 2,
        "{:?}",
        out.report
    );
    let border: std::collections::HashSet<_> = border_edges(&out.mesh).into_iter().collect();
    assert!(!border.is_empty());
    for &(p, q) in &border {
        assert!(border.contains(&(q, p)), "the seam was torn");
    }
    let seam_in = 2 * twin.len();
    let mut seam_out = 0;
    for (k, &v) in out.source_vertex.iter().enumerate() {
        if twin.contains_key(&v) || twin.values().any(|&t| t == v) {
            seam_out += 1;
            assert_eq!(
                out.mesh.positions[k], positions[v as usize],
                "seam vertex {v} moved"
            );
        }
    }
    // A curve on a surface reduced to a share s of its triangles keeps about √s of its vertices; a seam
    // may keep up to twice that (a locked seam keeps them all).
    let share = out.report.faces as f64 / seamed.n_faces() as f64;
    assert!(
        (seam_out as f64) <= 2.0 * share.sqrt() * seam_in as f64,
        "the seam did not reduce: {seam_out} of {seam_in} vertices kept, {:.1} % of the triangles",
        100.0 * share
    );
    // Three spheres side by side, rotated copies of one another: three pieces, kept.
    let mut t = gregvox::voxel::mesh::TriMesh::default();
    for k in 0..3 {
        let mut sheet = gregvox::voxel::mesh::TriMesh::sphere([0.0; 3], 1.0, 8, 16, false);
        let angle = k as f32 * 2.0;
        for p in &mut sheet.positions {
            let (x, y) = (p[0], p[1]);
            *p = [
                x * angle.cos() - y * angle.sin() + 2.5 * angle.cos(),
                x * angle.sin() + y * angle.cos() + 2.5 * angle.sin(),
                p[2],
            ];
        }
        t.append(&sheet);
    }
    // Three triangles on one edge (a fin): the non-manifold edge and its fans survive as they are.
    let fin = Mesh::from_polygons(
        vec![
            DVec3::ZERO,
            DVec3::X,
            DVec3::new(0.5, 1.0, 0.0),
            DVec3::new(0.5, -1.0, 0.0),
            DVec3::new(0.5, 0.0, 1.0),
        ],
        &[vec![0, 1, 2], vec![1, 0, 3], vec![0, 1, 4]],
    )
    .unwrap();
    let out = reduce(
        &fin,
        SimplifyOptions {
            faces: Some(0),
            ..Default::default()
        },
    );
    assert_eq!(out.report.faces, 3);
    assert_eq!(topology(&out.mesh).non_manifold_edges, 1);
    let many = of_trimesh(&t);
    let out = reduce(&many, ratio(0.2));
    assert_topology_kept("three spheres", &many, &out.mesh);
}

#[test]
fn the_result_does_not_depend_on_the_thread_count() {
    // The bunny is big enough for every parallel loop to split (PARALLEL_MIN) and for the vertex arrays
    // to be compacted with the candidates' costs carried across.
    for name in ["cow", "stanford-bunny"] {
        let input = load(name);
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| reduce(&input, ratio(0.1)))
        };
        let one = run(1);
        for threads in [2, 3, 5] {
            let other = run(threads);
            assert_eq!(
                other.mesh.indices, one.mesh.indices,
                "{name}: {threads} threads"
            );
            assert_eq!(
                other.mesh.positions, one.mesh.positions,
                "{name}: {threads} threads"
            );
            assert_eq!(other.report.error, one.report.error);
        }
    }
}

#[test]
fn levels_of_detail_reduce_each_from_the_previous() {
    let input = load("spot");
    let levels = simplify_lod(&input, &ratio(0.5), 4).unwrap();
    assert_eq!(levels.len(), 4);
    assert_eq!(levels[0].report.faces, input.n_faces());
    for k in 1..4 {
        let (prev, cur) = (&levels[k - 1], &levels[k]);
        assert_eq!(cur.report.input_faces, prev.report.faces);
        assert_eq!(cur.report.faces, prev.report.faces / 2);
        assert!(cur.report.error >= prev.report.error);
        assert_topology_kept("spot lod", &input, &cur.mesh);
        // Every vertex maps back to an input vertex.
        assert_eq!(cur.source_vertex.len(), cur.mesh.positions.len());
        assert!(cur
            .source_vertex
            .iter()
            .all(|&v| (v as usize) < input.positions.len()));
    }
    let by_faces = simplify_lod(
        &input,
        &SimplifyOptions {
            faces: Some(100),
            ..Default::default()
        },
        3,
    )
    .unwrap();
    assert!(by_faces[2].report.faces <= 100 && by_faces[1].report.faces < input.n_faces());
    assert!(simplify_lod(&input, &ratio(0.5), 0).is_err());
}

#[test]
fn small_pieces_are_kept_unless_pruned() {
    let mut t = gregvox::voxel::mesh::TriMesh::sphere([0.0; 3], 1.0, 24, 48, false);
    for k in 0..5 {
        t.append(&gregvox::voxel::mesh::TriMesh::sphere(
            [2.0 + k as f32 * 0.05, 0.0, 0.0],
            0.01,
            6,
            8,
            false,
        ));
    }
    let m = of_trimesh(&t);
    let kept = reduce(&m, ratio(0.01));
    assert_eq!(topology(&kept.mesh).face_components, 6);
    let pruned = reduce(
        &m,
        SimplifyOptions {
            ratio: Some(0.01),
            prune: 0.02,
            ..Default::default()
        },
    );
    assert_eq!(topology(&pruned.mesh).face_components, 1);
    assert_eq!(pruned.report.pruned_faces, 5 * 6 * 8 * 2 - 5 * 2 * 8);
}

#[test]
fn bad_options_and_empty_meshes_are_errors() {
    let m = load("spot");
    for opts in [
        SimplifyOptions {
            ratio: Some(f64::NAN),
            ..Default::default()
        },
        SimplifyOptions {
            ratio: Some(1.5),
            ..Default::default()
        },
        SimplifyOptions {
            error: Some(-1.0),
            ..Default::default()
        },
        SimplifyOptions {
            error: Some(f64::INFINITY),
            ..Default::default()
        },
        SimplifyOptions {
            prune: 2.0,
            ..Default::default()
        },
    ] {
        let e = simplify(&m, &opts).unwrap_err().to_string();
        assert!(e.contains("simplify"), "{e}");
    }
    // Meshes without faces cannot be built through the checked constructors; a hand-made one is refused.
    let empty = Mesh {
        positions: vec![DVec3::ZERO],
        face_ptr: vec![0],
        indices: vec![],
    };
    assert!(simplify(&empty, &ratio(0.5))
        .unwrap_err()
        .to_string()
        .contains("no faces"));
}

/// The inputs that attack the passes: an unwelded soup (every triangle its own piece: nothing may
/// collapse), one huge polygon (a 50,000-triangle fan around one vertex) and a fine grid.
#[test]
fn worst_cases_finish_and_keep_their_guarantees() {
    // Soup: the bunny's triangles, every one with its own three vertices.
    let bunny = load("stanford-bunny");
    let mut p = Vec::new();
    let mut f = Vec::new();
    for t in tris(&bunny) {
        let base = p.len() as u32;
        p.extend(t.map(DVec3::from_array));
        f.push(vec![base, base + 1, base + 2]);
    }
    let soup = Mesh::from_polygons(p, &f).unwrap();
    let out = reduce(&soup, ratio(0.1));
    assert_eq!(
        out.report.faces,
        soup.n_faces(),
        "lone triangles cannot be reduced"
    );
    assert!(out.report.passes <= 1);
    // One polygon of 50,000 corners (a disc), fanned from its first corner: one vertex of valence 50,000.
    let n = 50_000;
    let ring: Vec<DVec3> = (0..n)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            DVec3::new(a.cos(), a.sin(), 0.0)
        })
        .collect();
    let disc = Mesh::from_polygons(ring, &[(0..n as u32).collect()]).unwrap();
    let out = reduce(&disc, ratio(0.01));
    let t = topology(&out.mesh);
    assert_eq!(
        (
            t.boundary_loops,
            t.non_manifold_edges,
            t.euler_characteristic
        ),
        (1, 0, 1)
    );
    assert!(out.report.faces <= n / 100, "{}", out.report.faces);
    // A 256 × 256 grid, bent (131,072 triangles).
    let g = 256u32;
    let mut p = Vec::new();
    for j in 0..=g {
        for i in 0..=g {
            let (x, y) = (i as f64 / g as f64, j as f64 / g as f64);
            p.push(DVec3::new(x, y, 0.2 * (6.0 * x).sin() * (4.0 * y).cos()));
        }
    }
    let id = |i: u32, j: u32| j * (g + 1) + i;
    let mut f = Vec::new();
    for j in 0..g {
        for i in 0..g {
            f.push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            f.push(vec![id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    let grid = Mesh::from_polygons(p, &f).unwrap();
    let out = reduce(&grid, ratio(0.01));
    assert!(out.report.faces <= 1311);
    assert_topology_kept("grid", &grid, &out.mesh);
    assert_eq!(flipped(&grid, &out.mesh), 0);
}

#[test]
fn allow_topology_reduces_past_the_topological_minimum_without_degenerate_triangles() {
    let torus = of_trimesh(&gregvox::voxel::mesh::TriMesh::torus(
        [0.0; 3], 1.0, 0.3, 48, 24,
    ));
    let kept = reduce(
        &torus,
        SimplifyOptions {
            faces: Some(0),
            ..Default::default()
        },
    );
    let free = reduce(
        &torus,
        SimplifyOptions {
            faces: Some(0),
            allow_topology: true,
            ..Default::default()
        },
    );
    assert!(
        free.report.faces < kept.report.faces,
        "{} vs {}",
        free.report.faces,
        kept.report.faces
    );
    // Triangles never repeat a corner, and no two triangles share their three vertices.
    let mut seen = std::collections::HashSet::new();
    for f in 0..free.mesh.n_faces() {
        let mut t = [0u32; 3];
        t.copy_from_slice(free.mesh.face(f));
        assert!(t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
        t.sort_unstable();
        assert!(seen.insert(t), "duplicate triangle {t:?}");
    }
}

/// The boundary edges of a triangle mesh (edges of one triangle), as position pairs (bits) in the
/// triangle's direction.
fn border_edges(m: &Mesh) -> Vec<([u64; 3], [u64; 3])> {
    let key = |p: DVec3| p.to_array().map(f64::to_bits);
    let mut uses = std::collections::HashMap::new();
    for t in m.indices.chunks(3) {
        for k in 0..3 {
            let (u, v) = (t[k], t[(k + 1) % 3]);
            *uses.entry((u.min(v), u.max(v))).or_insert(0) += 1;
        }
    }
    let mut out = Vec::new();
    for t in m.indices.chunks(3) {
        for k in 0..3 {
            let (u, v) = (t[k], t[(k + 1) % 3]);
            if uses[&(u.min(v), u.max(v))] == 1 {
                out.push((key(m.positions[u as usize]), key(m.positions[v as usize])));
            }
        }
    }
    out
}

/// Output boundary edges (as position pairs) with no reversed edge at the same positions whose ends are
/// not both positions of the input's own borders (edges without such a twin): a torn seam shows up here.
fn torn_seam_edges(input: &Mesh, output: &Mesh) -> usize {
    let unmatched = |edges: &[([u64; 3], [u64; 3])]| -> Vec<([u64; 3], [u64; 3])> {
        let set: std::collections::HashSet<_> = edges.iter().copied().collect();
        edges
            .iter()
            .copied()
            .filter(|&(p, q)| !set.contains(&(q, p)))
            .collect()
    };
    let true_border: std::collections::HashSet<[u64; 3]> = unmatched(&border_edges(input))
        .into_iter()
        .flat_map(|(p, q)| [p, q])
        .collect();
    unmatched(&border_edges(output))
        .into_iter()
        .filter(|(p, q)| !(true_border.contains(p) && true_border.contains(q)))
        .count()
}

#[test]
fn seam_halves_that_share_neighbours_still_collapse_together_and_keep_the_seam_closed() {
    // Late in a deep reduction a patch between two seams is a strip, and the two halves of a seam
    // collapse share neighbours (90 % of the teapot's late seam candidates had closed one-rings that
    // met). Such a pair collapses when no vertex of one half neighbours the other and no opposite vertex
    // is shared; the seam stays closed and the topology is kept down to the smallest mesh.
    let teapot = load("teapot");
    // The check sees a tear: one seam vertex moved off its twin.
    let mut torn = teapot.clone();
    let key = |p: DVec3| p.to_array().map(f64::to_bits);
    let mut count = std::collections::HashMap::new();
    for p in &teapot.positions {
        *count.entry(key(*p)).or_insert(0) += 1;
    }
    let seam_vertex = (0..teapot.positions.len())
        .find(|&v| count[&key(teapot.positions[v])] == 2)
        .expect("the teapot has seams");
    torn.positions[seam_vertex].x += 1e-3;
    assert!(torn_seam_edges(&teapot, &torn) > 0);
    for (r, placement) in [
        (0.1, Placement::Optimal),
        (0.01, Placement::Optimal),
        (0.0, Placement::Optimal),
        (0.0, Placement::Keep),
    ] {
        let out = reduce(
            &teapot,
            SimplifyOptions {
                ratio: Some(r),
                placement,
                ..Default::default()
            },
        );
        let name = format!("teapot {r} {placement:?}");
        assert_topology_kept(&name, &teapot, &out.mesh);
        assert_eq!(
            torn_seam_edges(&teapot, &out.mesh),
            0,
            "{name}: a seam tore"
        );
        if r == 0.1 {
            assert!(out.report.faces <= 632, "{name}: {:?}", out.report);
        }
        if r == 0.0 {
            // With the halves' one-rings kept wholly apart it stopped at 490 faces (optimal placement)
            // and 588 (keep); now at 358 and 400.
            assert!(out.report.faces <= 420, "{name}: {:?}", out.report);
        }
    }
}
