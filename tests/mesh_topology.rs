//! Topology queries from E and M against libigl / trimesh fixtures and the figures of the issue.
mod mesh_common;
use gregvox::mesh::{load_obj, parse_obj, MeshMatrix, NONE};
use mesh_common::{model, read_u32, summary};
use std::collections::BTreeMap;

fn load(name: &str) -> (gregvox::mesh::Mesh, MeshMatrix) {
    let mesh = load_obj(model(&format!("{name}.obj"))).unwrap();
    let m = MeshMatrix::from_mesh(&mesh);
    (mesh, m)
}

/// Upper-triangle (i < j) pairs of our dual adjacency, row-major.
fn dual_pairs(m: &MeshMatrix) -> Vec<u32> {
    let a = m.dual_adjacency();
    let mut out = Vec::new();
    for f in 0..m.n_faces() {
        for &g in a.row(f).0 {
            if g as usize > f {
                out.extend_from_slice(&[f as u32, g]);
            }
        }
    }
    out
}

#[test]
fn face_adjacency_equals_libigl_facet_adjacency_matrix() {
    for name in ["stanford-bunny", "spot", "cow", "teapot"] {
        let (_, m) = load(name);
        let ours = dual_pairs(&m);
        let igl = read_u32(&format!("{name}.facet_adjacency.u32"));
        assert_eq!(ours.len(), igl.len(), "{name}: number of adjacent pairs");
        assert!(ours == igl, "{name}: adjacent pairs differ");
    }
}

#[test]
fn dual_adjacency_of_triangles_is_s_f_equal_to_two() {
    let (_, m) = load("cow");
    let sf = m.s_f();
    let ad = m.dual_adjacency();
    for f in 0..m.n_faces() {
        let (cols, vals) = sf.row(f);
        assert_eq!(sf.get(f, f as u32), Some(3), "diag(S_f) = face order");
        let twos: Vec<u32> = cols
            .iter()
            .zip(vals)
            .filter(|(&g, &v)| v == 2 && g as usize != f)
            .map(|(&g, _)| g)
            .collect();
        assert_eq!(twos, ad.row(f).0, "face {f}");
    }
}

#[test]
fn quads_sharing_a_diagonal_are_not_dual_adjacent() {
    // two quads sharing vertices 0 and 2 (a diagonal of each) but no edge
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 2 0\nv 1 2 1\nf 1 2 3 4\nf 1 3 5 6\n";
    let m = MeshMatrix::from_mesh(&parse_obj(text, "diag.obj").unwrap());
    assert_eq!(m.s_f().get(0, 1), Some(2), "S_f sees two shared vertices");
    assert!(
        m.dual_adjacency().row(0).0.is_empty(),
        "but E sees no shared edge"
    );
}

#[test]
fn bunny_has_five_boundary_loops_of_sizes_22_39_40_42_80() {
    let (_, m) = load("stanford-bunny");
    let mut sizes: Vec<usize> = m.boundary_loops().iter().map(|l| l.len()).collect();
    sizes.sort_unstable();
    assert_eq!(sizes, vec![22, 39, 40, 42, 80]);
    assert_eq!(m.boundary_half_edges().len(), 223);
    assert_eq!(m.euler_characteristic(), -3);
    assert_eq!(m.genus(), Some(0));
}

#[test]
fn loops_that_touch_at_pinched_vertices_are_counted_apart() {
    // The teapot is unwelded along its patches: 38 vertices where two boundary loops touch. Following
    // each loop through its own wedge gives 25 loops (counted independently with a half-edge walk in
    // Python: trimesh's faces, the next boundary half-edge found by turning round the head vertex);
    // taking the first free boundary half-edge at a vertex walked some pairs as figure eights (20).
    let (_, m) = load("teapot");
    let loops = m.boundary_loops();
    let mut sizes: Vec<usize> = loops.iter().map(|l| l.len()).collect();
    sizes.sort_unstable();
    assert_eq!(
        sizes,
        vec![
            4, 4, 12, 18, 20, 30, 30, 30, 30, 30, 30, 30, 30, 40, 40, 40, 40, 40, 48, 48, 50, 98,
            98, 98, 98
        ]
    );
    assert_eq!(sizes.iter().sum::<usize>(), m.boundary_half_edges().len());
    // Every loop is a closed chain of boundary half-edges (a loop may pass a vertex twice, through two
    // of its wedges: the teapot's loop of 50 does).
    for lp in &loops {
        for (k, &a) in lp.iter().enumerate() {
            let b = lp[(k + 1) % lp.len()];
            let e = m.find(a, b);
            assert!(e != gregvox::mesh::NONE && m.twins()[e as usize] == gregvox::mesh::NONE);
        }
    }
}

#[test]
fn a_star_touching_at_one_apex_and_a_huge_fan_give_their_own_loops() {
    // 10,000 triangles sharing only vertex 0: 10,000 loops of three through one pinched vertex.
    let n = 10_000u32;
    let star: Vec<u32> = (0..n).flat_map(|k| [0, 1 + 2 * k, 2 + 2 * k]).collect();
    let ptr: Vec<u32> = (0..=n).map(|k| 3 * k).collect();
    let m = MeshMatrix::new(1 + 2 * n, &ptr, star).unwrap();
    let loops = m.boundary_loops();
    assert_eq!(loops.len(), n as usize);
    assert!(loops.iter().all(|l| l.len() == 3 && l.contains(&0)));
    // A 100,000-gon as a fan from vertex 0: one loop through every vertex, the fan vertex's wedge of
    // 99,998 faces walked once.
    let g = 100_000u32;
    let fan: Vec<u32> = (1..g - 1).flat_map(|k| [0, k, k + 1]).collect();
    let ptr: Vec<u32> = (0..g - 1).map(|k| 3 * k).collect();
    let m = MeshMatrix::new(g, &ptr, fan).unwrap();
    let loops = m.boundary_loops();
    assert_eq!(loops.len(), 1);
    assert_eq!(loops[0].len(), g as usize);
}

#[test]
fn cow_has_exactly_one_pinched_vertex_253_and_chi_one() {
    let (_, m) = load("cow");
    let igl = summary()["meshes"]["cow"]["non_manifold_vertices"].clone();
    assert_eq!(igl, serde_json::json!([253]));
    assert_eq!(m.non_manifold_vertices(), vec![253]);
    assert_eq!(m.fans(253), 2);
    assert!(m.is_closed());
    assert_eq!(m.euler_characteristic(), 1);
    assert_eq!(m.genus(), None, "a pinched surface has no genus");
}

#[test]
fn teapot_has_4_vertex_components_and_19_face_components() {
    let (_, m) = load("teapot");
    assert_eq!(m.vertex_components().0, 4);
    assert_eq!(m.face_components().0, 19);
    let s = &summary()["meshes"]["teapot"];
    assert_eq!(s["facet_components"], 19);
    assert_eq!(s["vertex_components"], 4);
    assert_eq!(m.report().boundary_edges, 1036);
}

#[test]
fn suzanne_has_3_components() {
    let (_, m) = load("suzanne");
    assert_eq!(m.vertex_components().0, 3);
    assert_eq!(summary()["meshes"]["suzanne"]["trimesh_body_count"], 3);
}

#[test]
fn bunny_components_count_referenced_vertices_only() {
    let (_, m) = load("stanford-bunny");
    let (n, labels) = m.vertex_components();
    let s = &summary()["meshes"]["stanford-bunny"];
    // trimesh body_count counts each of the 1,113 unreferenced vertices as a body
    assert_eq!(s["trimesh_body_count"], 1114);
    assert_eq!(n, 1);
    assert_eq!(labels.iter().filter(|&&l| l == NONE).count(), 1113);
    assert_eq!(m.face_components().0, 1);
}

#[test]
fn report_figures_equal_the_oracles() {
    let s = summary();
    for name in ["stanford-bunny", "spot", "cow", "teapot"] {
        let (_, m) = load(name);
        let r = m.report();
        let o = &s["meshes"][name];
        assert_eq!(r.edges as u64, o["edges"].as_u64().unwrap(), "{name} edges");
        assert_eq!(
            r.boundary_edges as u64,
            o["boundary_edges"].as_u64().unwrap(),
            "{name} boundary"
        );
        assert_eq!(
            r.non_manifold_edges as u64,
            o["non_manifold_edges"].as_u64().unwrap(),
            "{name}"
        );
        assert_eq!(
            r.closed,
            o["trimesh_is_watertight"].as_bool().unwrap(),
            "{name} closed = watertight"
        );
        assert_eq!(
            r.unreferenced_vertices as u64,
            o["unreferenced_vertices"].as_u64().unwrap()
        );
        let hist: BTreeMap<String, usize> =
            serde_json::from_value(o["valence_histogram"].clone()).unwrap();
        assert_eq!(
            r.valence_histogram, hist,
            "{name} valence = igl.adjacency_list sizes"
        );
    }
}

#[test]
fn ordered_one_rings_equal_libigl_sorted_adjacency_up_to_rotation() {
    let (_, m) = load("spot");
    let text = std::fs::read_to_string(mesh_common::fixture("spot.one_rings.json")).unwrap();
    let rings: Vec<Vec<u32>> = serde_json::from_str(&text).unwrap();
    for (v, igl) in rings.iter().enumerate() {
        let ours = m.one_ring(v);
        assert_eq!(ours.len(), igl.len(), "vertex {v}");
        let k = igl
            .iter()
            .position(|&x| x == ours[0])
            .unwrap_or_else(|| panic!("vertex {v}"));
        let rotated: Vec<u32> = (0..igl.len()).map(|i| igl[(k + i) % igl.len()]).collect();
        assert_eq!(ours, rotated, "vertex {v}: same cyclic order");
    }
}

#[test]
fn faces_per_vertex_is_the_diagonal_of_s_v() {
    let (_, m) = load("spot");
    let igl = read_u32("spot.faces_per_vertex.u32");
    let sv = m.s_v();
    for (v, &n) in igl.iter().enumerate() {
        assert_eq!(sv.get(v, v as u32), Some(n), "vertex {v}");
    }
    // off-diagonal of S_v on a closed manifold triangle mesh: 2 for every edge, and only edges
    let adj = m.vertex_adjacency();
    for v in 0..m.n_verts() {
        let (cols, vals) = sv.row(v);
        let off: Vec<u32> = cols
            .iter()
            .zip(vals)
            .filter(|(&c, _)| c as usize != v)
            .map(|(&c, &x)| {
                assert_eq!(x, 2);
                c
            })
            .collect();
        assert_eq!(off, adj.row(v).0);
    }
}

#[test]
fn e_is_the_corner_walk_of_m() {
    // E[i, j] = f for every directed edge i → j of face f, and nothing else
    let (mesh, m) = load("suzanne");
    let e = m.half_edge_face();
    let vc = m.vertex_corners();
    let mut count = 0;
    for f in 0..mesh.n_faces() {
        let face = mesh.face(f);
        for k in 0..face.len() {
            let (i, j) = (face[k], face[(k + 1) % face.len()]);
            let entry = m.find(i, j);
            assert_ne!(entry, NONE);
            assert_eq!(e.face1[entry as usize], f as u32 + 1);
            count += 1;
        }
    }
    assert_eq!(count, e.col.len());
    assert_eq!(vc.ptr.len(), mesh.positions.len() + 1);
    // rows of Mᵀ are in increasing corner order (deterministic gathers)
    for v in 0..m.n_verts() {
        let row = &vc.corner[vc.ptr[v] as usize..vc.ptr[v + 1] as usize];
        assert!(row.windows(2).all(|w| w[0] < w[1]));
    }
}

#[test]
fn second_writes_flag_non_manifold_and_inconsistent_edges() {
    // three triangles on edge 1–2 (non-manifold), and a flipped pair elsewhere
    let nm = parse_obj(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n",
        "nm.obj",
    )
    .unwrap();
    let r = MeshMatrix::from_mesh(&nm).report();
    assert_eq!(
        (r.non_manifold_edges, r.second_writes, r.closed),
        (1, 1, false)
    );
    let flip = parse_obj(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 1 2 4\n",
        "flip.obj",
    )
    .unwrap();
    let r = MeshMatrix::from_mesh(&flip).report();
    assert_eq!(
        (
            r.inconsistent_edges,
            r.second_writes,
            r.consistently_oriented
        ),
        (1, 1, false)
    );
}

#[test]
fn collapsing_an_interior_edge_of_spot_removes_its_two_faces_and_keeps_chi() {
    let (_, m) = load("spot");
    // the edge of face 0 shared with face 2929 (notes A.3)
    let face0 = m.face(0).to_vec();
    let (mut keep, mut remove) = (NONE, NONE);
    for k in 0..3 {
        let (i, j) = (face0[k], face0[(k + 1) % 3]);
        let t = m.find(j, i);
        if t != NONE && m.half_edge_face().face1[t as usize] == 2930 {
            (keep, remove) = (i, j);
        }
    }
    assert_ne!(keep, NONE, "face 0 and face 2929 share an edge");
    let (c, map) = m.collapse_edge(keep, remove).unwrap();
    assert_eq!(c.n_faces(), m.n_faces() - 2);
    assert_eq!(c.n_verts(), m.n_verts() - 1);
    assert_eq!(c.euler_characteristic(), 2);
    assert!(c.is_closed());
    // faces other than 0 and 2929 survive in order, renumbered by the map
    let mut g = 0;
    for f in 0..m.n_faces() {
        if f == 0 || f == 2929 {
            continue;
        }
        let mapped: Vec<u32> = m.face(f).iter().map(|&v| map[v as usize]).collect();
        assert_eq!(c.face(g), &mapped[..]);
        g += 1;
    }
}

#[test]
fn welding_the_teapot_joins_its_patches() {
    let mesh = load_obj(model("teapot.obj")).unwrap();
    let (welded, map) = gregvox::mesh::weld(&mesh, 1e-7);
    let m0 = MeshMatrix::from_mesh(&mesh);
    let m1 = MeshMatrix::from_mesh(&welded);
    eprintln!(
        "teapot welded: {} → {} vertices",
        mesh.positions.len(),
        welded.positions.len()
    );
    assert!(welded.positions.len() < mesh.positions.len());
    assert_eq!(map.len(), mesh.positions.len());
    assert!(m1.face_components().0 < m0.face_components().0);
    assert!(m1.report().boundary_edges < m0.report().boundary_edges);
}

#[test]
fn twins_and_edge_ids_agree_with_a_brute_force_map() {
    // includes a non-manifold edge (1–2 in three faces) and a flipped face, where "first entry" rules matter
    let odd = parse_obj(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 2 2 2\nf 1 2 3\nf 2 1 4\nf 1 2 5\nf 3 2 6\nf 6 2 3\n",
        "odd.obj",
    )
    .unwrap();
    for mesh in [
        odd,
        load_obj(model("suzanne.obj")).unwrap(),
        load_obj(model("teapot.obj")).unwrap(),
    ] {
        let m = MeshMatrix::from_mesh(&mesh);
        let e = m.half_edge_face();
        let ptr = &m.vertex_corners().ptr;
        let mut ids: std::collections::HashMap<(u32, u32), u32> = std::collections::HashMap::new();
        for i in 0..m.n_verts() {
            for k in ptr[i]..ptr[i + 1] {
                let j = e.col[k as usize];
                let first_twin =
                    (ptr[j as usize]..ptr[j as usize + 1]).find(|&t| e.col[t as usize] == i as u32);
                assert_eq!(m.twins()[k as usize], first_twin.unwrap_or(NONE));
                let key = (j.min(i as u32), j.max(i as u32));
                let id = m.half_edge_edge()[k as usize];
                assert_eq!(
                    *ids.entry(key).or_insert(id),
                    id,
                    "one id per unordered pair"
                );
                assert_eq!(
                    {
                        let [a, b] = m.edge_vertices(id as usize);
                        (a.min(b), a.max(b))
                    },
                    key
                );
            }
        }
        assert_eq!(ids.len(), m.n_edges());
    }
}
