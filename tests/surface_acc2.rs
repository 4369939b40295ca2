//! ACC-2 stencils vs OpenSubdiv 3.5 (fixtures from tests/oracle/osd_gregory.cpp), B-spline reproduction,
//! planar cages, corners, bad input.
#[path = "surface_common.rs"]
mod common;
use common::*;
use glam::DVec3;
use gregvox::mesh::{load_obj, Mesh, MeshMatrix};
use gregvox::surface::{GregoryStencils, Tangents};

const FIXTURES: &[&str] = &[
    "catmark_cube",
    "catmark_torus",
    "catmark_gregory_test0",
    "catmark_gregory_test1",
    "catmark_gregory_test6",
    "catmark_gregory_test8_r1",
    "catmark_tent",
    "catmark_flap",
    "catmark_nonquads_r1",
    "spot_quadrangulated",
];

#[test]
fn stencils_match_opensubdiv_points() {
    let mut worst = 0.0f64;
    for name in FIXTURES {
        let fx = read_fixture(name);
        let mesh = Mesh::from_polygons(fx.cage.clone(), &fx.faces).unwrap();
        let s = GregoryStencils::new(&MeshMatrix::from_mesh(&mesh), Tangents::OpenSubdiv).unwrap();
        let patches = s.patches_f64(&fx.cage).unwrap();
        let d = diag(&fx.cage);
        let mut err = 0.0f64;
        let mut worst_at = (0, 0);
        for (f, p) in patches.iter().enumerate() {
            assert_eq!(
                s.regular[f],
                fx.types[f] == 0,
                "{name}: face {f} patch type differs from OpenSubdiv"
            );
            for j in 0..20 {
                let e = (p.cv[j] - fx.points[f][j]).length() / d;
                if e > err {
                    err = e;
                    worst_at = (f, j);
                }
            }
        }
        let n_reg = s.regular.iter().filter(|&&r| r).count();
        eprintln!(
            "{name:28} {:5} patches ({n_reg} regular), {:6} rows, max |W·cage − OSD|/diag = {err:.2e} (face {}, point {}){}",
            patches.len(),
            s.w.n_rows,
            worst_at.0,
            worst_at.1,
            if fx.f32_points { " [f32 fixture]" } else { "" }
        );
        let tol = if fx.f32_points { 1e-6 } else { 1e-12 };
        assert!(err <= tol, "{name}: {err:e} > {tol:e}");
        if !fx.f32_points {
            worst = worst.max(err);
        }
    }
    eprintln!("worst over f64 fixtures: {worst:.2e} · diag");
}

#[test]
fn fixture_cages_are_the_shared_models() {
    // The oracle parsed the OBJ itself: make sure our loader sees the same cage (same order).
    for name in [
        "catmark_cube",
        "catmark_torus",
        "catmark_gregory_test6",
        "catmark_tent",
    ] {
        let fx = read_fixture(name);
        let mesh = load_obj(model(&format!("opensubdiv/{name}.obj"))).unwrap();
        assert_eq!(mesh.positions.len(), fx.cage.len(), "{name}");
        for (a, b) in mesh.positions.iter().zip(&fx.cage) {
            assert!((*a - *b).length() < 1e-12, "{name}");
        }
        for f in 0..fx.faces.len() {
            assert_eq!(mesh.face(f), &fx.faces[f][..], "{name}: face {f}");
        }
    }
}

#[test]
fn osd_samples_match_patch_evaluation() {
    // OpenSubdiv's own evaluation (approximate Gregory derivatives) vs our f64 patches: positions everywhere,
    // derivatives on the edges (where approximate = exact) and via approx_derivatives inside.
    let mut worst = (0.0f64, 0.0f64);
    for name in FIXTURES {
        let fx = read_fixture(name);
        if fx.samples[0].is_empty() {
            continue;
        }
        let mesh = Mesh::from_polygons(fx.cage.clone(), &fx.faces).unwrap();
        let s = GregoryStencils::new(&MeshMatrix::from_mesh(&mesh), Tangents::OpenSubdiv).unwrap();
        let patches = s.patches_f64(&fx.cage).unwrap();
        let d = diag(&fx.cage);
        for (f, p) in patches.iter().enumerate() {
            for smp in &fx.samples[f] {
                let (u, v) = (smp[0], smp[1]);
                let (pos, du, dv) = p.approx_derivatives(u, v);
                let e = (pos - DVec3::new(smp[2], smp[3], smp[4])).length() / d;
                let ed = ((du - DVec3::new(smp[5], smp[6], smp[7])).length()
                    + (dv - DVec3::new(smp[8], smp[9], smp[10])).length())
                    / d;
                worst.0 = worst.0.max(e);
                worst.1 = worst.1.max(ed);
            }
        }
    }
    eprintln!(
        "OSD EvaluateBasis vs PatchF64: position {:.2e}·diag, derivatives {:.2e}·diag",
        worst.0, worst.1
    );
    assert!(worst.0 < 1e-12 && worst.1 < 1e-12, "{worst:?}");
}

/// The uniform cubic B-spline basis.
fn bspline(t: f64) -> [f64; 4] {
    let s = 1.0 - t;
    [
        s * s * s / 6.0,
        (3.0 * t * t * t - 6.0 * t * t + 4.0) / 6.0,
        (-3.0 * t * t * t + 3.0 * t * t + 3.0 * t + 1.0) / 6.0,
        t * t * t / 6.0,
    ]
}

/// Derivatives of the uniform cubic B-spline basis.
fn dbspline(t: f64) -> [f64; 4] {
    let s = 1.0 - t;
    [
        -s * s / 2.0,
        (3.0 * t * t - 4.0 * t) / 2.0,
        (-3.0 * t * t + 2.0 * t + 1.0) / 2.0,
        t * t / 2.0,
    ]
}

/// The quad containing the directed edge i → j, rotated to start at i.
fn quad_of(m: &MeshMatrix, i: u32, j: u32) -> [u32; 4] {
    let k = m.find(i, j);
    assert_ne!(k, gregvox::mesh::NONE);
    let f = (m.half_edge_face().face1[k as usize] - 1) as usize;
    let q = m.face(f);
    let r = q.iter().position(|&x| x == i).unwrap();
    std::array::from_fn(|t| q[(r + t) % 4])
}

/// Is vertex v interior with 4 faces and 4 neighbours?
fn interior_valence4(m: &MeshMatrix, v: u32) -> bool {
    let vc = m.vertex_corners();
    vc.ptr[v as usize + 1] - vc.ptr[v as usize] == 4
        && m.valence(v as usize) == 4
        && m.one_ring(v as usize)
            .iter()
            .all(|&w| m.find(w, v) != gregvox::mesh::NONE && m.find(v, w) != gregvox::mesh::NONE)
}

/// The 4×4 B-spline control grid p[row = v][col = u] of a face with only valence-4 interior corners.
fn bspline_grid(m: &MeshMatrix, f: usize) -> [[u32; 4]; 4] {
    let v = m.face(f);
    let mut p = [[0u32; 4]; 4];
    p[1][1] = v[0];
    p[1][2] = v[1];
    p[2][2] = v[2];
    p[2][1] = v[3];
    let b = quad_of(m, v[1], v[0]);
    (p[0][1], p[0][2]) = (b[2], b[3]);
    let r = quad_of(m, v[2], v[1]);
    (p[1][3], p[2][3]) = (r[2], r[3]);
    let t = quad_of(m, v[3], v[2]);
    (p[3][2], p[3][1]) = (t[2], t[3]);
    let l = quad_of(m, v[0], v[3]);
    (p[2][0], p[1][0]) = (l[2], l[3]);
    p[0][0] = quad_of(m, v[0], p[1][0])[2];
    p[0][3] = quad_of(m, v[1], p[0][2])[2];
    p[3][3] = quad_of(m, v[2], p[2][3])[2];
    p[3][0] = quad_of(m, v[3], p[3][1])[2];
    p
}

#[test]
fn torus_reproduces_the_bicubic_bspline() {
    let mesh = load_obj(model("opensubdiv/catmark_torus.obj")).unwrap();
    let m = MeshMatrix::from_mesh(&mesh);
    let s = GregoryStencils::new(&m, Tangents::OpenSubdiv).unwrap();
    assert!(s.regular.iter().all(|&r| r));
    let patches = s.patches_f64(&mesh.positions).unwrap();
    let d = diag(&mesh.positions);
    let (mut err, mut derr, mut nerr) = (0.0f64, 0.0f64, 0.0f64);
    for (f, patch) in patches.iter().enumerate() {
        // f+ = f−: every face-point pair is one row
        for i in 0..4 {
            assert_eq!(s.patch_points[f][5 * i + 3], s.patch_points[f][5 * i + 4]);
        }
        let g = bspline_grid(&m, f);
        for j in 0..=32 {
            for i in 0..=32 {
                let (u, v) = (i as f64 / 32.0, j as f64 / 32.0);
                let (bu, bv) = (bspline(u), bspline(v));
                let mut x = DVec3::ZERO;
                for (r, row) in g.iter().enumerate() {
                    for (c, &k) in row.iter().enumerate() {
                        x += bu[c] * bv[r] * mesh.positions[k as usize];
                    }
                }
                err = err.max((patch.eval(u, v).0 - x).length() / d);
                // exact B-spline partial derivatives vs the patch's (polynomial, so exact) S_u, S_v
                let (du, dv) = (dbspline(u), dbspline(v));
                let (mut xu, mut xv) = (DVec3::ZERO, DVec3::ZERO);
                for (r, row) in g.iter().enumerate() {
                    for (c, &k) in row.iter().enumerate() {
                        xu += du[c] * bv[r] * mesh.positions[k as usize];
                        xv += bu[c] * dv[r] * mesh.positions[k as usize];
                    }
                }
                let (_, su, sv) = patch.eval(u, v);
                derr = derr.max(((su - xu).length() + (sv - xv).length()) / d);
                nerr = nerr.max(angle(patch.normal(u, v), xu.cross(xv)));
            }
        }
    }
    eprintln!("catmark_torus vs direct B-spline, 33² per face: |ΔP| ≤ {err:.2e}·diag, |ΔS_u|+|ΔS_v| ≤ {derr:.2e}·diag, normal ≤ {nerr:.2e} rad");
    assert!(err <= 1e-12, "{err:e}");
    assert!(derr <= 1e-12, "{derr:e}");
    assert!(nerr <= 1e-10, "{nerr:e}");
}

#[test]
fn planar_cage_stays_planar_with_linear_precision() {
    // Build the cage explicitly: 8×8 squares; square (3,3) is split by its diagonal (3,3)-(4,4) into two
    // triangles; the upper triangle merges with square (3,4) above into a pentagon.
    let n = 8usize;
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let plane_n = DVec3::new(-0.3, 0.2, 1.0).normalize();
    let z = |x: f64, y: f64| 0.3 * x - 0.2 * y + 1.0;
    let mut pos = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f64, j as f64);
            pos.push(DVec3::new(x, y, z(x, y)));
        }
    }
    let mut faces = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let q = vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)];
            match (i, j) {
                (3, 3) => faces.push(vec![id(3, 3), id(4, 3), id(4, 4)]),
                (3, 4) => faces.push(vec![id(3, 3), id(4, 4), id(4, 5), id(3, 5), id(3, 4)]),
                _ => faces.push(q),
            }
        }
    }
    let mesh = Mesh::from_polygons(pos, &faces).unwrap();
    let cs = GregoryStencils::from_mesh(&mesh, Tangents::OpenSubdiv).unwrap();
    eprintln!("{}", cs.note.as_deref().unwrap_or("no refinement"));
    assert!(cs.note.is_some());
    let qm = MeshMatrix::from_mesh(&cs.quad_mesh);
    let hist = qm.report().valence_histogram;
    assert!(hist.contains_key("3") && hist.contains_key("5"), "{hist:?}");
    let patches = cs.stencils.patches_f64(&mesh.positions).unwrap();
    let d = diag(&mesh.positions);
    let origin = DVec3::new(0.0, 0.0, 1.0);
    let (mut dz, mut dn, mut lin, mut n_lin) = (0.0f64, 0.0f64, 0.0f64, 0);
    for (f, p) in patches.iter().enumerate() {
        for j in 0..=8 {
            for i in 0..=8 {
                let (u, v) = (i as f64 / 8.0, j as f64 / 8.0);
                let x = p.eval(u, v).0;
                dz = dz.max((x - origin).dot(plane_n).abs() / d);
                dn = dn.max(angle(p.normal(u, v), plane_n));
            }
        }
        // Linear precision on regular faces whose support is a uniform lattice of the face.
        if !cs.stencils.regular[f] {
            continue;
        }
        let fv = qm.face(f);
        let q = &cs.quad_mesh.positions;
        let (o, a, b) = (
            q[fv[0] as usize],
            q[fv[1] as usize] - q[fv[0] as usize],
            q[fv[3] as usize] - q[fv[0] as usize],
        );
        let on_lattice = |x: DVec3| {
            // solve x − o = s·a + t·b in the plane
            let r = x - o;
            let (aa, ab, bb) = (a.dot(a), a.dot(b), b.dot(b));
            let det = aa * bb - ab * ab;
            let (ra, rb) = (r.dot(a), r.dot(b));
            let s = (ra * bb - rb * ab) / det;
            let t = (rb * aa - ra * ab) / det;
            (s - s.round()).abs() < 1e-9
                && (t - t.round()).abs() < 1e-9
                && (o + s * a + t * b - x).length() < 1e-9
        };
        if !fv.iter().all(|&v| interior_valence4(&qm, v)) {
            continue;
        }
        if !bspline_grid(&qm, f)
            .iter()
            .flatten()
            .all(|&w| on_lattice(q[w as usize]))
        {
            continue;
        }
        n_lin += 1;
        for j in 0..=8 {
            for i in 0..=8 {
                let (u, v) = (i as f64 / 8.0, j as f64 / 8.0);
                lin = lin.max((p.eval(u, v).0 - (o + u * a + v * b)).length() / d);
            }
        }
    }
    eprintln!(
        "plane: {} patches, |distance| ≤ {dz:.2e}·diag, normal ≤ {dn:.2e} rad; linear precision on {n_lin} faces ≤ {lin:.2e}·diag",
        patches.len()
    );
    assert!(dz <= 1e-12 && dn <= 1e-9);
    assert!(n_lin > 50, "{n_lin}");
    assert!(lin <= 1e-12, "{lin:e}");
}

#[test]
fn corners_are_finite_limit_points_with_one_normal() {
    for (name, path) in [
        ("catmark_cube", model("opensubdiv/catmark_cube.obj")),
        ("spot_quadrangulated", model("spot_quadrangulated.obj")),
        (
            "catmark_gregory_test6",
            model("opensubdiv/catmark_gregory_test6.obj"),
        ),
    ] {
        let mesh = load_obj(&path).unwrap();
        let m = MeshMatrix::from_mesh(&mesh);
        let s = GregoryStencils::new(&m, Tangents::OpenSubdiv).unwrap();
        let pts = s.points(&mesh.positions).unwrap();
        let patches = s.patches_f64(&mesh.positions).unwrap();
        let d = diag(&mesh.positions);
        let ts = [0.0, 1e-7, 1e-4, 1.0 - 1e-7, 1.0];
        let mut corner_err = 0.0f64;
        let mut tangent_err = 0.0f64;
        // per cage vertex: the first corner normal seen, and the max deviation
        let mut first: Vec<Option<DVec3>> = vec![None; mesh.positions.len()];
        let mut spread = 0.0f64;
        for (f, p) in patches.iter().enumerate() {
            for &u in &ts {
                for &v in &ts {
                    let (x, su, sv) = p.eval(u, v);
                    assert!(
                        x.is_finite() && su.is_finite() && sv.is_finite(),
                        "{name}: face {f} at ({u}, {v})"
                    );
                    assert!(p.normal(u, v).is_finite());
                }
            }
            for (i, (u, v)) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
                .into_iter()
                .enumerate()
            {
                let vtx = m.face(f)[i] as usize;
                let prow = s.patch_points[f][5 * i] as usize;
                assert_eq!(prow, vtx, "P row of vertex {vtx} is row {vtx}");
                corner_err = corner_err.max((p.eval(u, v).0 - pts[prow]).length() / d);
                let n = p.normal(u, v);
                let (ep, em) = (
                    pts[s.patch_points[f][5 * i + 1] as usize],
                    pts[s.patch_points[f][5 * i + 2] as usize],
                );
                let stencil_n = (ep - pts[prow]).cross(em - pts[prow]).normalize();
                tangent_err = tangent_err.max(angle(n, stencil_n));
                match first[vtx] {
                    None => first[vtx] = Some(n),
                    Some(n0) => spread = spread.max(angle(n, n0)),
                }
            }
        }
        eprintln!(
            "{name}: corner − P ≤ {corner_err:.1e}·diag, corner normal vs (Ep−P)×(Em−P) ≤ {tangent_err:.1e} rad, spread around a vertex ≤ {spread:.1e} rad"
        );
        assert!(corner_err <= 1e-14);
        assert!(tangent_err <= 1e-9);
        assert!(spread <= 1e-9, "{name}: {spread:e}");
    }
}

#[test]
fn exact_tangents_differ_only_at_irregular_interior_corners() {
    let mesh = load_obj(model("opensubdiv/catmark_cube.obj")).unwrap();
    let m = MeshMatrix::from_mesh(&mesh);
    let a = GregoryStencils::new(&m, Tangents::OpenSubdiv).unwrap();
    let b = GregoryStencils::new(&m, Tangents::Exact).unwrap();
    assert_eq!(a.patch_points, b.patch_points);
    let (pa, pb) = (
        a.points(&mesh.positions).unwrap(),
        b.points(&mesh.positions).unwrap(),
    );
    // P rows equal, edge rows differ (valence 3 everywhere): |Ep − P| ratio .2879/.2286 on a symmetric ring
    for v in 0..8 {
        assert!((pa[v] - pb[v]).length() < 1e-15);
    }
    let (ea, eb) = (
        (pa[8] - pa[m.corner_vertex()[0] as usize]).length(),
        (pb[8] - pb[m.corner_vertex()[0] as usize]).length(),
    );
    eprintln!(
        "cube |Ep−P|: OpenSubdiv {ea:.4}, exact {eb:.4}, ratio {:.4} (symmetric ring: {:.4})",
        eb / ea,
        0.2879 / 0.2286
    );
    assert!((eb / ea - 0.2879 / 0.2286).abs() < 2e-3);
    // torus: all regular, identical
    let torus = load_obj(model("opensubdiv/catmark_torus.obj")).unwrap();
    let tm = MeshMatrix::from_mesh(&torus);
    let ta = GregoryStencils::new(&tm, Tangents::OpenSubdiv).unwrap();
    let tb = GregoryStencils::new(&tm, Tangents::Exact).unwrap();
    assert_eq!(ta.w, tb.w);
}

#[test]
fn w_rows_are_affine_and_f32_matches() {
    let mesh = load_obj(model("spot_quadrangulated.obj")).unwrap();
    let t0 = std::time::Instant::now();
    let s = GregoryStencils::new(&MeshMatrix::from_mesh(&mesh), Tangents::OpenSubdiv).unwrap();
    let dt = t0.elapsed();
    eprintln!(
        "spot_quadrangulated: W built in {:.1} ms ({} rows × {} cols, {} nnz, {:.1} nnz/row; 20 × patches = {})",
        dt.as_secs_f64() * 1e3,
        s.w.n_rows,
        s.w.n_cols,
        s.w.nnz(),
        s.w.nnz() as f64 / s.w.n_rows as f64,
        20 * s.patch_points.len()
    );
    let mut worst = 0.0f64;
    for r in 0..s.w.n_rows as usize {
        let (_, val) = s.w.row(r);
        worst = worst.max((val.iter().sum::<f64>() - 1.0).abs());
    }
    assert!(worst < 1e-12, "row sum off by {worst:e}");
    // every row is used by some patch
    let mut used = vec![false; s.w.n_rows as usize];
    for pp in &s.patch_points {
        for &r in pp {
            used[r as usize] = true;
        }
    }
    assert!(used.iter().all(|&u| u));
    let w32 = s.w_f32();
    let cage32: Vec<[f32; 3]> = mesh
        .positions
        .iter()
        .map(|p| p.as_vec3().to_array())
        .collect();
    let p32 = w32.spmv_f32(&cage32);
    let p64 = s.points(&mesh.positions).unwrap();
    let d = diag(&mesh.positions);
    let e = p32
        .iter()
        .zip(&p64)
        .map(|(a, b)| (DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64) - *b).length() / d)
        .fold(0.0, f64::max);
    eprintln!("f32 W·cage vs f64: {e:.2e}·diag");
    assert!(e < 1e-6);
}

#[test]
fn bad_cages_are_clear_errors() {
    // non-manifold edge: three quads on one edge
    let p: Vec<DVec3> = (0..8)
        .map(|i| DVec3::new(i as f64, (i * i) as f64, 0.0))
        .collect();
    let m = Mesh::from_polygons(
        p.clone(),
        &[vec![0, 1, 2, 3], vec![1, 0, 4, 5], vec![0, 1, 6, 7]],
    )
    .unwrap();
    let e = GregoryStencils::from_mesh(&m, Tangents::OpenSubdiv)
        .unwrap_err()
        .to_string();
    assert!(e.contains("manifold"), "{e}");
    // non-manifold vertex: two quads touching at one vertex
    let p: Vec<DVec3> = (0..7).map(|i| DVec3::new(i as f64, 1.0, 0.0)).collect();
    let m = Mesh::from_polygons(p, &[vec![0, 1, 2, 3], vec![0, 4, 5, 6]]).unwrap();
    let e = GregoryStencils::from_mesh(&m, Tangents::OpenSubdiv)
        .unwrap_err()
        .to_string();
    assert!(e.contains("manifold"), "{e}");
    // inconsistent orientation
    let p: Vec<DVec3> = (0..6).map(|i| DVec3::new(i as f64, 1.0, 0.0)).collect();
    let m = Mesh::from_polygons(p, &[vec![0, 1, 2, 3], vec![0, 1, 4, 5]]).unwrap();
    let e = GregoryStencils::from_mesh(&m, Tangents::OpenSubdiv)
        .unwrap_err()
        .to_string();
    assert!(e.contains("orient") || e.contains("manifold"), "{e}");
    // catmark_gregory_test4 has a pinched vertex (two one-face fans) and catmark_fan non-manifold edges
    // (three faces on one edge): OpenSubdiv accepts both, gregvox refuses non-manifold cages.
    let fan = load_obj(model("opensubdiv/catmark_fan.obj")).unwrap();
    let e = GregoryStencils::from_mesh(&fan, Tangents::OpenSubdiv)
        .unwrap_err()
        .to_string();
    assert!(e.contains("non-manifold edges"), "{e}");
    // The first such edge is named, with its face count.
    assert!(
        e.contains("is shared by 3 faces") && e.contains("edge "),
        "{e}"
    );
    let t4 = load_obj(model("opensubdiv/catmark_gregory_test4.obj")).unwrap();
    let e = GregoryStencils::from_mesh(&t4, Tangents::OpenSubdiv)
        .unwrap_err()
        .to_string();
    assert!(e.contains("non-manifold vertices"), "{e}");
    assert!(e.contains("joins separate fans"), "{e}");
    // empty cage (no faces)
    let empty = MeshMatrix::new(3, &[0], vec![]).unwrap();
    let e = GregoryStencils::new(&empty, Tangents::OpenSubdiv)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no faces"), "{e}");
    // degenerate geometry (all vertices at one point) is accepted and evaluates without NaN
    let cube = load_obj(model("opensubdiv/catmark_cube.obj")).unwrap();
    let faces: Vec<Vec<u32>> = (0..cube.n_faces()).map(|f| cube.face(f).to_vec()).collect();
    let blob = Mesh::from_polygons(vec![DVec3::ONE; 8], &faces).unwrap();
    let cs = GregoryStencils::from_mesh(&blob, Tangents::OpenSubdiv).unwrap();
    for p in cs.stencils.patches_f64(&blob.positions).unwrap() {
        assert!(p.eval(0.5, 0.5).0.is_finite() && p.normal(0.3, 0.0).is_finite());
    }
    // wrong cage length / NaN
    let quad = Mesh::from_polygons(
        vec![DVec3::ZERO, DVec3::X, DVec3::ONE, DVec3::Y],
        &[vec![0, 1, 2, 3]],
    )
    .unwrap();
    let cs = GregoryStencils::from_mesh(&quad, Tangents::OpenSubdiv).unwrap();
    assert!(cs.stencils.points(&[DVec3::ZERO]).is_err());
    assert!(cs
        .stencils
        .points(&[DVec3::ZERO, DVec3::X, DVec3::NAN, DVec3::Y])
        .is_err());
}

/// OpenSubdiv's exact Catmull–Clark limit per cage vertex (`PrimvarRefiner::Limit`): (P, tan1, tan2).
fn read_limit(name: &str) -> Vec<[DVec3; 3]> {
    let path = format!(
        "{}/tests/fixtures/surface/{name}.limit",
        env!("CARGO_MANIFEST_DIR")
    );
    let b = std::fs::read(path).unwrap();
    assert_eq!(b.len() % 72, 0);
    let f = |k: usize| f64::from_le_bytes(b[8 * k..8 * k + 8].try_into().unwrap());
    (0..b.len() / 72)
        .map(|v| {
            std::array::from_fn(|i| {
                DVec3::new(f(9 * v + 3 * i), f(9 * v + 3 * i + 1), f(9 * v + 3 * i + 2))
            })
        })
        .collect()
}

#[test]
fn exact_tangents_put_corner_normals_on_the_limit_tangent_plane() {
    // Closed cages: every vertex interior. P rows are the exact limit points in both modes; the corner
    // normal is the exact limit normal with Tangents::Exact, and only approximately with OpenSubdiv's masks.
    for name in ["catmark_cube", "spot_quadrangulated"] {
        let path = if name == "catmark_cube" {
            model("opensubdiv/catmark_cube.obj")
        } else {
            model("spot_quadrangulated.obj")
        };
        let mesh = load_obj(path).unwrap();
        let lim = read_limit(name);
        assert_eq!(lim.len(), mesh.positions.len());
        let m = MeshMatrix::from_mesh(&mesh);
        let d = diag(&mesh.positions);
        let mut figures = Vec::new();
        for t in [Tangents::OpenSubdiv, Tangents::Exact] {
            let s = GregoryStencils::new(&m, t).unwrap();
            let pts = s.points(&mesh.positions).unwrap();
            let patches = s.patches_f64(&mesh.positions).unwrap();
            let (mut perr, mut nerr) = (0.0f64, 0.0f64);
            for (f, p) in patches.iter().enumerate() {
                for (i, (u, v)) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
                    .into_iter()
                    .enumerate()
                {
                    let vtx = m.face(f)[i] as usize;
                    perr = perr.max((pts[vtx] - lim[vtx][0]).length() / d);
                    let n_lim = lim[vtx][1].cross(lim[vtx][2]);
                    // Signed: OpenSubdiv's limit tangents (tan1, tan2) at a vertex follow the orientation of
                    // its faces, so a flipped patch normal shows as π.
                    nerr = nerr.max(angle(p.normal(u, v), n_lim));
                }
            }
            eprintln!("{name}: {t:?}: P vs limit {perr:.1e}·diag, corner normal vs limit tangent plane {nerr:.2e} rad ({:.3}°)", nerr.to_degrees());
            figures.push((perr, nerr));
        }
        assert!(figures[0].0 <= 1e-12 && figures[1].0 <= 1e-12);
        assert!(
            figures[1].1 <= 1e-9,
            "{name}: exact mode off the limit plane by {:e}",
            figures[1].1
        );
        if name == "spot_quadrangulated" {
            assert!(
                figures[0].1 > 1e-4,
                "OpenSubdiv masks are expected off the limit plane at EVs"
            );
        }
    }
}

#[test]
fn from_mesh_on_non_quad_cages_matches_opensubdiv_refine_then_iso0() {
    // gregvox: our Catmull–Clark step folded into W; OpenSubdiv: Far uniform level 1, then isolation 0. The
    // vertex numberings differ, so match patches geometrically, up to a rotation of the corner order
    // (a cyclic shift of the 5-point corner blocks).
    for (name, obj) in [
        ("catmark_nonquads_r1", "opensubdiv/catmark_nonquads.obj"),
        (
            "catmark_gregory_test8_r1",
            "opensubdiv/catmark_gregory_test8.obj",
        ),
    ] {
        let fx = read_fixture(name);
        let mesh = load_obj(model(obj)).unwrap();
        let cs = GregoryStencils::from_mesh(&mesh, Tangents::OpenSubdiv).unwrap();
        let ours = cs.stencils.patches_f64(&mesh.positions).unwrap();
        assert_eq!(ours.len(), fx.points.len());
        let theirs: Vec<&[DVec3; 20]> = fx.points.iter().collect();
        let worst = worst_matched_patch(name, &ours, &theirs) / diag(&mesh.positions);
        eprintln!("{name}: from_mesh (CC folded into W) vs OpenSubdiv refine + iso 0: max {worst:.1e}·diag over {} patches", ours.len());
        assert!(worst <= 1e-12, "{name}: {worst:e}");
    }
}
