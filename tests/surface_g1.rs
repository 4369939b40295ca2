//! G1 continuity of ACC-2 patches across every interior edge (static, deformed, non-quad cages), the
//! negative control, shared boundary rows, and the tessellator contract.
#[path = "surface_common.rs"]
mod common;
use common::*;
use glam::DVec3;
use gregvox::geom::gregory::PatchF64;
use gregvox::mesh::{load_obj, Mesh, MeshMatrix, NONE};
use gregvox::surface::{indices, tessellate, write_tessellation_obj, GregoryStencils, Tangents};

const GAP: f64 = 1e-12; // · diag
const JUMP: f64 = 1e-6; // rad

fn check_static(name: &str, mesh: &Mesh, tangents: Tangents) -> f64 {
    let s = GregoryStencils::new(&MeshMatrix::from_mesh(mesh), tangents).unwrap();
    let patches = s.patches_f64(&mesh.positions).unwrap();
    let d = diag(&mesh.positions);
    let G1 {
        gap,
        jump,
        edges,
        skipped,
    } = g1_figures(mesh, &patches, 33);
    eprintln!(
        "{name:24} {tangents:?}: {edges} interior edges × 33: gap {:.1e}·diag, normal jump {jump:.1e} rad",
        gap / d
    );
    assert_eq!(skipped, 0, "{name}: no degenerate corners expected");
    assert!(gap <= GAP * d, "{name}: gap {:e}", gap / d);
    assert!(jump <= JUMP, "{name}: jump {jump:e}");
    jump
}

fn cages() -> Vec<(&'static str, Mesh)> {
    vec![
        (
            "catmark_cube",
            load_obj(model("opensubdiv/catmark_cube.obj")).unwrap(),
        ),
        (
            "spot_quadrangulated",
            load_obj(model("spot_quadrangulated.obj")).unwrap(),
        ),
        (
            "catmark_gregory_test6",
            load_obj(model("opensubdiv/catmark_gregory_test6.obj")).unwrap(),
        ),
        (
            "catmark_gregory_test1",
            load_obj(model("opensubdiv/catmark_gregory_test1.obj")).unwrap(),
        ),
    ]
}

#[test]
fn g1_static_both_tangent_modes() {
    for (name, mesh) in cages() {
        for t in [Tangents::OpenSubdiv, Tangents::Exact] {
            check_static(name, &mesh, t);
        }
    }
    // valence 2 (OpenSubdiv's own refinement of catmark_gregory_test8, see the fixture)
    let fx = read_fixture("catmark_gregory_test8_r1");
    let mesh = Mesh::from_polygons(fx.cage, &fx.faces).unwrap();
    // Valence-2 corners have Ep = Em = P (OpenSubdiv's σ_2 = 0, matched by the oracle test): S_u = S_v = 0
    // there and the normal is undefined, so g1_figures skips exactly those corner samples.
    let s = GregoryStencils::new(&MeshMatrix::from_mesh(&mesh), Tangents::OpenSubdiv).unwrap();
    let patches = s.patches_f64(&mesh.positions).unwrap();
    let r = g1_figures(&mesh, &patches, 33);
    eprintln!(
        "catmark_gregory_test8_r1: {} edges, gap {:.1e}, normal jump {:.1e} rad, {} valence-2 corner samples skipped",
        r.edges, r.gap, r.jump, r.skipped
    );
    assert!(r.skipped > 0, "test8 has valence-2 vertices");
    assert!(r.gap <= GAP * diag(&mesh.positions) && r.jump <= JUMP);
    // The exact-tangent mask at valence 2 gives Em − P = −(Ep − P): again no tangent plane at the corner.
    let s = GregoryStencils::new(&MeshMatrix::from_mesh(&mesh), Tangents::Exact).unwrap();
    let patches = s.patches_f64(&mesh.positions).unwrap();
    let r = g1_figures(&mesh, &patches, 33);
    eprintln!(
        "catmark_gregory_test8_r1 Exact: gap {:.1e}, normal jump {:.1e} rad, {} samples skipped",
        r.gap, r.jump, r.skipped
    );
    assert!(r.skipped > 0);
    assert!(r.gap <= GAP * diag(&mesh.positions) && r.jump <= JUMP);
}

#[test]
fn g1_survives_random_deformations() {
    for (name, mesh) in cages() {
        if name == "catmark_gregory_test1" {
            continue;
        }
        let m = MeshMatrix::from_mesh(&mesh);
        let s = GregoryStencils::new(&m, Tangents::OpenSubdiv).unwrap();
        let d = diag(&mesh.positions);
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15 ^ mesh.positions.len() as u64);
        let (mut worst_gap, mut worst_jump) = (0.0f64, 0.0f64);
        let t0 = std::time::Instant::now();
        for _ in 0..20 {
            let cage: Vec<DVec3> = mesh
                .positions
                .iter()
                .map(|&p| p + rng.ball(0.01 * d))
                .collect();
            let patches = s.patches_f64(&cage).unwrap();
            let moved = Mesh {
                positions: cage.clone(),
                ..mesh.clone()
            };
            let r = g1_figures(&moved, &patches, 33);
            assert_eq!(r.skipped, 0);
            worst_gap = worst_gap.max(r.gap / diag(&cage));
            worst_jump = worst_jump.max(r.jump);
        }
        eprintln!(
            "{name:24} 20 random deformations (≤ 1 % diag per vertex): gap {worst_gap:.1e}·diag, jump {worst_jump:.1e} rad ({:.1} s)",
            t0.elapsed().as_secs_f64()
        );
        assert!(worst_gap <= GAP && worst_jump <= JUMP, "{name}");
    }
}

#[test]
fn negative_control_plain_bezier_breaks_g1() {
    let mesh = load_obj(model("spot_quadrangulated.obj")).unwrap();
    let s = GregoryStencils::new(&MeshMatrix::from_mesh(&mesh), Tangents::OpenSubdiv).unwrap();
    let patches: Vec<PatchF64> = s
        .patches_f64(&mesh.positions)
        .unwrap()
        .into_iter()
        .map(|mut p| {
            for (a, b) in [(3, 4), (9, 8), (19, 18), (13, 14)] {
                let m = (p.cv[a] + p.cv[b]) * 0.5;
                p.cv[a] = m;
                p.cv[b] = m;
            }
            p
        })
        .collect();
    let G1 { gap, jump, .. } = g1_figures(&mesh, &patches, 33);
    eprintln!(
        "spot with face-point pairs averaged (plain Bézier): gap {gap:.1e}, normal jump {:.2}° ",
        jump.to_degrees()
    );
    assert!(
        jump > 1e-2,
        "the G1 check cannot see a broken surface: {jump:e}"
    );
}

#[test]
fn non_quad_cages_refine_once_then_g1() {
    for (name, path) in [
        ("spot_control_mesh", model("spot_control_mesh.obj")),
        ("catmark_nonquads", model("opensubdiv/catmark_nonquads.obj")),
        (
            "catmark_gregory_test8",
            model("opensubdiv/catmark_gregory_test8.obj"),
        ),
        ("suzanne", model("suzanne.obj")),
    ] {
        let mesh = load_obj(&path).unwrap();
        let cs = GregoryStencils::from_mesh(&mesh, Tangents::OpenSubdiv).unwrap();
        let note = cs.note.clone().expect("non-quad cages are refined");
        assert!(note.contains("Catmull"));
        let patches = cs.stencils.patches_f64(&mesh.positions).unwrap();
        assert_eq!(patches.len(), cs.quad_mesh.n_faces());
        let d = diag(&mesh.positions);
        let G1 {
            gap,
            jump,
            edges,
            skipped,
        } = g1_figures(&cs.quad_mesh, &patches, 33);
        eprintln!(
            "{name:20} {note}; {edges} edges: gap {:.1e}·diag, jump {jump:.1e} rad ({skipped} valence-2 corner samples skipped)",
            gap / d
        );
        assert!(gap <= GAP * d, "{name}");
        assert!(jump <= JUMP, "{name}: {jump:e}");
    }
}

#[test]
fn neighbours_share_boundary_rows() {
    // The 4 boundary points of a shared edge are the same W rows in both patches (bit-identical on the GPU).
    const EDGE: [[usize; 4]; 4] = [
        [0, 1, 7, 5],
        [5, 6, 12, 10],
        [10, 11, 17, 15],
        [15, 16, 2, 0],
    ];
    let mesh = load_obj(model("spot_quadrangulated.obj")).unwrap();
    let m = MeshMatrix::from_mesh(&mesh);
    let s = GregoryStencils::new(&m, Tangents::OpenSubdiv).unwrap();
    let twin = twin_corners(&m);
    let mut n = 0;
    for (c, &t) in twin.iter().enumerate() {
        if t == NONE {
            continue;
        }
        let (f, i, g, k) = (c / 4, c % 4, t as usize / 4, t as usize % 4);
        let a: Vec<u32> = EDGE[i].iter().map(|&j| s.patch_points[f][j]).collect();
        let mut b: Vec<u32> = EDGE[k].iter().map(|&j| s.patch_points[g][j]).collect();
        b.reverse();
        assert_eq!(a, b, "faces {f}/{g}");
        n += 1;
    }
    assert_eq!(n, 2 * 5856);
}

#[test]
fn tessellation_follows_the_contract() {
    let mesh = load_obj(model("opensubdiv/catmark_cube.obj")).unwrap();
    let s = GregoryStencils::new(&MeshMatrix::from_mesh(&mesh), Tangents::OpenSubdiv).unwrap();
    let patches = s.patches_f64(&mesh.positions).unwrap();
    let l = 8u32;
    let t = tessellate(&patches, l);
    let row = (l + 1) as usize;
    assert_eq!(t.positions.len(), patches.len() * row * row);
    for (p, patch) in patches.iter().enumerate() {
        for j in 0..row {
            for i in 0..row {
                let k = p * row * row + j * row + i;
                let (u, v) = (i as f64 / l as f64, j as f64 / l as f64);
                assert_eq!(t.positions[k], patch.eval(u, v).0);
                assert!((t.normals[k].length() - 1.0).abs() < 1e-12);
            }
        }
        // u along v0→v1: vertex 1 of the grid lies toward cage vertex face[1]
        let f = mesh.face(p);
        let (c0, c1, c3) = (
            mesh.positions[f[0] as usize],
            mesh.positions[f[1] as usize],
            mesh.positions[f[3] as usize],
        );
        let base = p * row * row;
        assert!((t.positions[base + 1] - t.positions[base]).dot(c1 - c0) > 0.0);
        assert!((t.positions[base + row] - t.positions[base]).dot(c3 - c0) > 0.0);
    }
    // every triangle faces the way its vertex normals do (CCW = outward on a CCW cage)
    let idx = indices(l, patches.len());
    assert_eq!(idx.len(), patches.len() * 6 * (l * l) as usize);
    let mut worst = 1.0f64;
    for tri in idx.chunks(3) {
        let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| t.positions[i as usize]);
        let n = (b - a).cross(c - a).normalize();
        let vn =
            (t.normals[tri[0] as usize] + t.normals[tri[1] as usize] + t.normals[tri[2] as usize])
                .normalize();
        worst = worst.min(n.dot(vn));
    }
    eprintln!("cube level {l}: min cos(triangle normal, vertex normals) = {worst:.4}");
    assert!(worst > 0.9);
    // the cube is closed and convex: normals point away from the centre
    let centre = mesh.positions.iter().sum::<DVec3>() / mesh.positions.len() as f64;
    assert!(t
        .positions
        .iter()
        .zip(&t.normals)
        .all(|(p, n)| (*p - centre).dot(*n) > 0.0));
    let path = std::env::temp_dir().join(format!("gregvox_surface_g1_{}.obj", std::process::id()));
    write_tessellation_obj(&path, &t, l).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_eq!(
        text.lines().filter(|x| x.starts_with("v ")).count(),
        t.positions.len()
    );
    assert_eq!(
        text.lines().filter(|x| x.starts_with("vn ")).count(),
        t.positions.len()
    );
    assert_eq!(
        text.lines().filter(|x| x.starts_with("f ")).count(),
        idx.len() / 3
    );
    // a mismatched level is an error, not a panic
    assert!(write_tessellation_obj(&path, &t, 5).is_err());
}
