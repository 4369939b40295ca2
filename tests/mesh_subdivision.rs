//! Catmull–Clark and Loop subdivision as sparse matrices, against closed forms, a published CC² pair
//! and the libigl / trimesh Loop oracles.
mod mesh_common;
use glam::DVec3;
use gregvox::mesh::{
    catmull_clark, catmull_clark_matrix, load_obj, loop_matrix, parse_obj, rows_sum_to_one,
    LoopBeta, MeshMatrix, SubdivisionStack,
};
use mesh_common::{canonical_face, model, nearest, read_f64x3};
use std::collections::HashSet;

const CUBE: &str =
    "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

#[test]
fn cube_first_level_has_corners_at_five_ninths_edges_at_three_quarters() {
    let cube = parse_obj(CUBE, "cube.obj").unwrap();
    let out = catmull_clark(&cube, 1);
    assert_eq!((out.positions.len(), out.n_faces()), (26, 24));
    // vertex points first: each corner moves to (5/9)(±1, ±1, ±1); closed form, f64 rounding only
    for (i, p) in out.positions[..8].iter().enumerate() {
        let expect = cube.positions[i] * (5.0 / 9.0);
        assert!(
            (*p - expect).abs().max_element() <= 1e-15,
            "corner {i}: {p} vs {expect}"
        );
    }
    // face points (next 6) are the face centres (unit distance along one axis)
    for p in &out.positions[8..14] {
        assert!(
            (p.abs().max_element() - 1.0).abs() <= 1e-15
                && (p.abs().element_sum() - 1.0).abs() <= 1e-15
        );
    }
    // edge points (last 12): two coordinates ±3/4, one 0
    for p in &out.positions[14..] {
        let mut a = p.abs().to_array();
        a.sort_by(|x, y| x.partial_cmp(y).unwrap());
        assert!(
            a[0].abs() <= 1e-15 && (a[1] - 0.75).abs() <= 1e-15 && (a[2] - 0.75).abs() <= 1e-15,
            "{p}"
        );
    }
    let m = MeshMatrix::from_mesh(&out);
    assert!(m.is_closed() && m.report().consistently_oriented);
    assert_eq!(m.euler_characteristic(), 2);
}

#[test]
fn catmull_clark_twice_of_spot_control_equals_spot_quadrangulated() {
    let control = load_obj(model("spot_control_mesh.obj")).unwrap();
    let reference = load_obj(model("spot_quadrangulated.obj")).unwrap();
    let ours = catmull_clark(&control, 2);
    assert_eq!(ours.positions.len(), reference.positions.len());
    assert_eq!(ours.n_faces(), reference.n_faces());
    // vertex matching: nearest reference vertex for each of ours; tolerance 1e-5 from the issue (the
    // file prints 6 decimals, so ~6.7e-6 is the expected worst case)
    let nn = nearest(&ours.positions, &reference.positions, 1e-3);
    let worst = nn.iter().map(|x| x.1).fold(0.0, f64::max);
    eprintln!("spot CC² max vertex distance {worst:e}");
    assert!(worst <= 1e-5, "max distance {worst}");
    let map: Vec<u32> = nn.iter().map(|x| x.0 as u32).collect();
    let distinct: HashSet<u32> = map.iter().copied().collect();
    assert_eq!(distinct.len(), map.len(), "the matching is a bijection");
    let ref_faces: HashSet<Vec<u32>> = (0..reference.n_faces())
        .map(|f| canonical_face(reference.face(f)))
        .collect();
    let our_faces: HashSet<Vec<u32>> = (0..ours.n_faces())
        .map(|f| {
            canonical_face(
                &ours
                    .face(f)
                    .iter()
                    .map(|&v| map[v as usize])
                    .collect::<Vec<_>>(),
            )
        })
        .collect();
    assert_eq!(our_faces, ref_faces, "identical oriented faces");
}

#[test]
fn subdivision_matrix_rows_are_affine_and_the_stack_is_one_spmv_per_level() {
    let control = load_obj(model("spot_control_mesh.obj")).unwrap();
    let m = MeshMatrix::from_mesh(&control);
    let stack = SubdivisionStack::catmull_clark(&m, 2);
    for l in &stack.levels {
        assert!(rows_sum_to_one(&l.s, 1e-14));
        assert!(l.s.row_ptr.windows(2).all(|w| w[0] <= w[1]));
    }
    assert_eq!(
        stack.levels[1].topology.layout(),
        &gregvox::mesh::FaceLayout::Stride(4)
    );
    // a deforming cage: the stack applied to moved positions = subdividing the moved mesh from scratch
    let mut moved = control.clone();
    for (i, p) in moved.positions.iter_mut().enumerate() {
        *p += DVec3::new((i as f64).sin(), 0.1 * i as f64 % 1.0, 0.0) * 0.01;
    }
    let a = stack.apply(&moved.positions);
    let b = catmull_clark(&moved, 2).positions;
    // catmull_clark is staged (face points first, then one SpMV over old points and face points) so that
    // its memory is linear in polygon size; the stack expands the face points: equal to rounding.
    let worst = a
        .iter()
        .zip(&b)
        .map(|(p, q)| (*p - *q).length())
        .fold(0.0, f64::max);
    assert!(worst <= 1e-14, "{worst}");
    // f32 path (the GPU twin) stays within 2e-5 of f64 on this 2-unit model
    let s32: Vec<_> = stack.levels.iter().map(|l| l.s.to_f32()).collect();
    let mut p32: Vec<[f32; 3]> = moved
        .positions
        .iter()
        .map(|p| p.as_vec3().to_array())
        .collect();
    for s in &s32 {
        p32 = s.spmv_f32(&p32);
    }
    let err = p32
        .iter()
        .zip(&a)
        .map(|(x, y)| {
            (DVec3::new(x[0] as f64, x[1] as f64, x[2] as f64) - *y)
                .abs()
                .max_element()
        })
        .fold(0.0, f64::max);
    assert!(err <= 2e-5, "f32 vs f64 {err}");
}

#[test]
fn open_quad_uses_the_edge_only_boundary_rule() {
    // a 3×3 grid of quads in the plane: boundary edge points are midpoints, boundary vertices (6,1,1)/8,
    // the whole result stays in the plane z = 0
    let mut text = String::new();
    for j in 0..4 {
        for i in 0..4 {
            text += &format!("v {i} {j} 0\n");
        }
    }
    for j in 0..3 {
        for i in 0..3 {
            let v = 1 + i + 4 * j;
            text += &format!("f {} {} {} {}\n", v, v + 1, v + 5, v + 4);
        }
    }
    let grid = parse_obj(&text, "grid.obj").unwrap();
    let m = MeshMatrix::from_mesh(&grid);
    let sub = catmull_clark_matrix(&m);
    let p = sub.s.spmv(&grid.positions);
    // vertex 1 = (1,0,0) on the bottom boundary with boundary neighbours (0,0,0), (2,0,0): stays put
    assert_eq!(p[1], DVec3::new(1.0, 0.0, 0.0));
    // corner vertex 0 has two boundary edges: (6·0 + 1·(1,0) + 1·(0,1))/8
    assert_eq!(p[0], DVec3::new(0.125, 0.125, 0.0));
    // a regular interior vertex of a planar uniform grid stays put
    assert!((p[5] - DVec3::new(1.0, 1.0, 0.0)).length() < 1e-15);
    assert!(p.iter().all(|q| q.z == 0.0));
}

/// Point-set comparison of Loop results (the oracles number odd vertices differently).
fn assert_same_points(ours: &[DVec3], oracle: &[DVec3], tol: f64, what: &str) {
    assert_eq!(ours.len(), oracle.len(), "{what}: vertex count");
    let nn = nearest(ours, oracle, 1e-2);
    let worst = nn.iter().map(|x| x.1).fold(0.0, f64::max);
    eprintln!("{what}: max distance {worst:e}");
    assert!(worst <= tol, "{what}: max distance {worst}");
    let distinct: HashSet<usize> = nn.iter().map(|x| x.0).collect();
    assert_eq!(distinct.len(), ours.len(), "{what}: bijection");
}

#[test]
fn loop_with_warrens_beta_equals_libigl_on_spot() {
    let spot = load_obj(model("spot.obj")).unwrap();
    let sub = loop_matrix(&MeshMatrix::from_mesh(&spot), LoopBeta::Warren).unwrap();
    let ours = sub.s.spmv(&spot.positions);
    // even vertices keep their index in libigl's output: compare them by index too
    let igl = read_f64x3("spot.loop_igl.f64");
    let even = (0..spot.positions.len())
        .map(|i| (ours[i] - igl[i]).abs().max_element())
        .fold(0.0, f64::max);
    assert!(even <= 1e-12, "even vertices {even}");
    assert_same_points(&ours, &igl, 1e-12, "loop (Warren) vs igl.loop");
}

#[test]
fn loop_with_loops_beta_equals_trimesh_on_spot() {
    let spot = load_obj(model("spot.obj")).unwrap();
    let sub = loop_matrix(&MeshMatrix::from_mesh(&spot), LoopBeta::Loop).unwrap();
    let ours = sub.s.spmv(&spot.positions);
    assert_same_points(
        &ours,
        &read_f64x3("spot.loop_trimesh.f64"),
        1e-12,
        "loop (Loop β) vs trimesh",
    );
    // and the two β really differ (so the two tests above can tell them apart)
    let warren = loop_matrix(&MeshMatrix::from_mesh(&spot), LoopBeta::Warren)
        .unwrap()
        .s
        .spmv(&spot.positions);
    let diff = ours
        .iter()
        .zip(&warren)
        .map(|(a, b)| (*a - *b).length())
        .fold(0.0, f64::max);
    assert!(diff > 1e-4, "β variants differ by {diff}");
}

#[test]
fn loop_refuses_polygons() {
    let quad = parse_obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n", "q.obj").unwrap();
    let err = loop_matrix(&MeshMatrix::from_mesh(&quad), LoopBeta::Warren).unwrap_err();
    assert!(err.to_string().contains("triangle"));
}

#[test]
fn loop_with_loops_beta_equals_trimesh_on_the_pinched_cow() {
    // vertex 253 has two fans; its even rule uses all its distinct neighbours, as trimesh does
    let cow = load_obj(model("cow.obj")).unwrap();
    let sub = loop_matrix(&MeshMatrix::from_mesh(&cow), LoopBeta::Loop).unwrap();
    let ours = sub.s.spmv(&cow.positions);
    let oracle = read_f64x3("cow.loop_trimesh.f64");
    let even = (0..cow.positions.len())
        .map(|i| (ours[i] - oracle[i]).abs().max_element())
        .fold(0.0, f64::max);
    assert!(even <= 1e-12, "even vertices by index: {even}");
    assert_same_points(&ours, &oracle, 1e-12, "loop (Loop β) vs trimesh on cow");
}

#[test]
fn regular_periodic_quad_grid_equals_bicubic_b_spline_refinement() {
    // A perturbed 8×6 torus grid: away from extraordinary vertices Catmull–Clark is uniform bicubic
    // B-spline knot insertion, i.e. the tensor product of the 1D stencils (1/8, 6/8, 1/8) (vertex) and
    // (1/2, 1/2) (edge). Closed form, so the tolerance is f64 rounding (1e-12).
    let (nu, nv) = (8usize, 6usize);
    let id = |i: usize, j: usize| (i % nu) + nu * (j % nv);
    let mut text = String::new();
    for j in 0..nv {
        for i in 0..nu {
            let (u, v) = (
                i as f64 / nu as f64 * std::f64::consts::TAU,
                j as f64 / nv as f64 * std::f64::consts::TAU,
            );
            let jitter = 0.05 * ((7 * i + 3 * j) as f64).sin();
            let (r, big) = (1.0 + jitter, 3.0);
            text += &format!(
                "v {} {} {}\n",
                (big + r * v.cos()) * u.cos(),
                (big + r * v.cos()) * u.sin(),
                r * v.sin() + 0.1 * jitter
            );
        }
    }
    for j in 0..nv {
        for i in 0..nu {
            text += &format!(
                "f {} {} {} {}\n",
                id(i, j) + 1,
                id(i + 1, j) + 1,
                id(i + 1, j + 1) + 1,
                id(i, j + 1) + 1
            );
        }
    }
    let torus = parse_obj(&text, "torus.obj").unwrap();
    let p = &torus.positions;
    let m = MeshMatrix::from_mesh(&torus);
    assert_eq!((m.is_closed(), m.euler_characteristic()), (true, 0));
    let out = catmull_clark_matrix(&m).s.spmv(p);
    let at = |i: usize, j: usize, a: usize, b: usize| p[id(i + a + nu - 1, j + b + nv - 1)];
    let mut expect_vertex = Vec::new();
    let mut expect_face = Vec::new();
    let mut expect_edge = Vec::new();
    let w3 = [0.125, 0.75, 0.125];
    for j in 0..nv {
        for i in 0..nu {
            let mut q = DVec3::ZERO;
            for (b, wb) in w3.iter().enumerate() {
                for (a, wa) in w3.iter().enumerate() {
                    q += wa * wb * at(i, j, a, b);
                }
            }
            expect_vertex.push(q);
            expect_face.push(
                0.25 * (p[id(i, j)] + p[id(i + 1, j)] + p[id(i + 1, j + 1)] + p[id(i, j + 1)]),
            );
            // edge (i,j)–(i+1,j): (1/2, 1/2) along u, (1/8, 6/8, 1/8) along v
            let mut eu = DVec3::ZERO;
            let mut ev = DVec3::ZERO;
            for (b, wb) in w3.iter().enumerate() {
                eu += 0.5 * wb * (at(i, j, 1, b) + at(i, j, 2, b));
                ev += 0.5 * wb * (at(i, j, b, 1) + at(i, j, b, 2));
            }
            expect_edge.push(eu);
            expect_edge.push(ev);
        }
    }
    let n = nu * nv;
    for k in 0..n {
        assert!(
            (out[k] - expect_vertex[k]).length() <= 1e-12,
            "vertex point {k}"
        );
        assert!(
            (out[n + k] - expect_face[k]).length() <= 1e-12,
            "face point {k}"
        );
    }
    assert_same_points(&out[2 * n..], &expect_edge, 1e-12, "torus edge points");
}

#[test]
fn hidden_edges_join_chaikins_average_and_decay_with_the_level() {
    // A 2×1 strip: its middle edge (vertices 1–4) semi-sharp 2.5. At vertex 1 two hidden edges of 1.0 (what a
    // seam vertex's UV-cage span does not have) join Chaikin's average: the middle edge's half at vertex 1
    // decays to 0.75·2.5 + 0.25·1.0 − 1 = 1.125 (uniform: 1.5, Chaikin alone: 1.5), the hidden ones to
    // 0.75·1 + 0.25·1.75 − 1 = 0.1875 and ride on to the vertex point; without Chaikin they change nothing.
    use gregvox::mesh::{catmull_clark_matrix_creased, catmull_clark_matrix_creased_hidden};
    let strip = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nv 1 1 0\nv 2 1 0\nf 1 2 5 4\nf 2 3 6 5\n";
    let mesh = parse_obj(strip, "strip.obj").unwrap();
    let m = MeshMatrix::from_mesh(&mesh);
    let mid = m.edge_id(1, 4).unwrap();
    let mut es = vec![0.0f32; m.n_edges()];
    es[mid] = 2.5;
    let vs = vec![0.0f32; m.n_verts()];
    let mut hidden = vec![Vec::new(); m.n_verts()];
    hidden[1] = vec![1.0, 1.0];
    let c = catmull_clark_matrix_creased_hidden(&m, &es, &vs, true, &hidden);
    let nv = m.n_verts() as u32;
    let edge_point = nv + m.n_faces() as u32 + mid as u32;
    let half_at = |c: &gregvox::mesh::CreasedSubdivision, v: u32| {
        c.edge_sharpness[c.sub.topology.edge_id(v, edge_point).unwrap()]
    };
    assert_eq!(half_at(&c, 1), 1.125);
    assert_eq!(half_at(&c, 4), 1.5);
    assert_eq!(c.hidden[1], vec![0.1875, 0.1875]);
    assert!(c
        .hidden
        .iter()
        .enumerate()
        .all(|(v, h)| v == 1 || h.is_empty()));
    let plain = catmull_clark_matrix_creased(&m, &es, &vs, true);
    assert_eq!(half_at(&plain, 1), 1.5);
    let uniform = catmull_clark_matrix_creased_hidden(&m, &es, &vs, false, &hidden);
    assert_eq!(half_at(&uniform, 1), 1.5);
    assert!(uniform.hidden.is_empty());
}
