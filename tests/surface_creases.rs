//! Tagged cages (OpenSubdiv's `t crease`, `t corner`, `t hole`, `t interpolateboundary`) against OpenSubdiv
//! 3.5 with `useInfSharpPatch` at isolation 0 (fixtures from tests/oracle/osd_gregory.cpp, which reads the
//! same OBJ tags): the same patches, points and patch types; creases C0 with a fold, the rest still
//! smooth; bad tags and what cannot be honoured refused with the tag named. Semi-sharp cages are checked
//! against OpenSubdiv's adaptive patches in tests/surface_evaluate.rs.
#[path = "surface_common.rs"]
mod common;
use common::*;
use glam::DVec3;
use gregvox::mesh::{load_obj_cage, parse_obj_cage, Cage, MeshMatrix};
use gregvox::surface::{Features, GregoryStencils, Tangents};

/// All-quad tagged shapes: (fixture, cage file).
const TAGGED: &[(&str, &str)] = &[
    (
        "catmark_cube_corner4",
        "opensubdiv/catmark_cube_corner4.obj",
    ),
    ("catmark_edgecorner", "opensubdiv/catmark_edgecorner.obj"),
    ("catmark_edgenone", "opensubdiv/catmark_edgenone.obj"),
    ("catmark_hole_test1", "opensubdiv/catmark_hole_test1.obj"),
    ("catmark_hole_test4", "opensubdiv/catmark_hole_test4.obj"),
    ("catmark_inf_crease0", "opensubdiv/catmark_inf_crease0.obj"),
    ("catmark_inf_crease1", "opensubdiv/catmark_inf_crease1.obj"),
    (
        "catmark_xord_boundary",
        "opensubdiv/catmark_xord_boundary.obj",
    ),
    ("catmark_quadstrips", "opensubdiv/catmark_quadstrips.obj"),
    ("catmark_fvar_bound4", "opensubdiv/catmark_fvar_bound4.obj"),
    (
        "catmark_xord_interior",
        "opensubdiv/catmark_xord_interior.obj",
    ),
    ("quads_dart", "fixture:quads_dart.obj"),
];

fn cage_path(rel: &str) -> String {
    match rel.strip_prefix("fixture:") {
        Some(f) => format!(
            "{}/tests/fixtures/surface/cages/{f}",
            env!("CARGO_MANIFEST_DIR")
        ),
        None => model(rel),
    }
}

fn load(rel: &str) -> Cage {
    load_obj_cage(cage_path(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

#[test]
fn tagged_opensubdiv_shapes_give_opensubdivs_patches_point_for_point() {
    let mut worst = 0.0f64;
    let (mut n_sharp_edges, mut n_sharp_verts, mut n_holes) = (0, 0, 0);
    let mut n_skipped = 0;
    for &(name, rel) in TAGGED {
        let fx = read_fixture(name);
        let cage = load(rel);
        // The oracle read the same file: same cage, same order.
        assert_eq!(cage.mesh.positions.len(), fx.cage.len(), "{name}");
        for (a, b) in cage.mesh.positions.iter().zip(&fx.cage) {
            assert!((*a - *b).length() < 1e-6, "{name}: positions differ");
        }
        for f in 0..fx.faces.len() {
            assert_eq!(cage.mesh.face(f), &fx.faces[f][..], "{name}: face {f}");
        }
        let m = MeshMatrix::from_mesh(&cage.mesh);
        let features = Features::from_tags(&m, &cage.tags).unwrap();
        n_sharp_edges += features.sharp_edge.iter().filter(|&&s| s).count();
        n_sharp_verts += features.sharp_vertex.iter().filter(|&&s| s).count();
        n_holes += features.hole.iter().filter(|&&s| s).count();
        let cs = GregoryStencils::from_cage(&cage, Tangents::OpenSubdiv).unwrap();
        let s = &cs.stencils;
        let expected_faces: Vec<u32> = (0..fx.types.len() as u32)
            .filter(|&f| fx.types[f as usize] != 2)
            .collect();
        assert_eq!(
            s.patch_face, expected_faces,
            "{name}: the faces with a patch (holes skipped) differ from OpenSubdiv's"
        );
        // The fixture's cage (f64 from the oracle's parse) evaluates the stencils.
        let patches = s.patches_f64(&fx.cage).unwrap();
        let d = diag(&fx.cage);
        let mut err = 0.0f64;
        for (k, (p, &f)) in patches.iter().zip(&s.patch_face).enumerate() {
            let f = f as usize;
            assert_eq!(
                s.regular[k],
                fx.types[f] == 0,
                "{name}: face {f}: patch type (regular = B-spline) differs from OpenSubdiv"
            );
            // Type 3: OpenSubdiv 3.5 wrote a face-point row that is not affine (an overflow next to
            // darts; the oracle reports it): its P, Ep, Em are compared, its face points cannot be.
            for j in (0..20).filter(|j| fx.types[f] != 3 || j % 5 < 3) {
                err = err.max((p.cv[j] - fx.points[f][j]).length() / d);
            }
            n_skipped += (fx.types[f] == 3) as usize;
        }
        let n_reg = s.regular.iter().filter(|&&r| r).count();
        eprintln!(
            "{name:24} {:3} patches ({n_reg:2} regular) of {:3} faces, max |W·cage − OSD|/diag = {err:.1e}",
            patches.len(),
            fx.types.len()
        );
        assert!(err <= 1e-12, "{name}: {err:e}");
        worst = worst.max(err);
    }
    eprintln!(
        "worst {worst:.1e}·diag over {} shapes with {n_sharp_edges} sharp edges, {n_sharp_verts} sharp vertices, {n_holes} holes",
        TAGGED.len()
    );
    // The set really exercises every feature; OpenSubdiv's overflowing rows stay the exception (quads_dart's
    // faces 6 and 7, where darts meet an L-shaped crease).
    assert!(n_sharp_edges >= 30 && n_sharp_verts >= 5 && n_holes >= 20);
    assert_eq!(
        n_skipped, 2,
        "patches whose face points OpenSubdiv got wrong"
    );
}

#[test]
fn tagged_shapes_evaluate_as_opensubdiv_evaluates_them() {
    // OpenSubdiv's EvaluateBasis (its approximate Gregory derivatives) against our f64 patches at 16
    // (u, v) per patch.
    let mut worst = (0.0f64, 0.0f64);
    for &(name, rel) in TAGGED {
        let fx = read_fixture(name);
        let cage = load(rel);
        let s = GregoryStencils::from_cage(&cage, Tangents::OpenSubdiv)
            .unwrap()
            .stencils;
        let patches = s.patches_f64(&fx.cage).unwrap();
        let d = diag(&fx.cage);
        for (p, &f) in patches.iter().zip(&s.patch_face) {
            if fx.types[f as usize] == 3 {
                continue; // OpenSubdiv's face points are wrong there (see above)
            }
            for smp in &fx.samples[f as usize] {
                let (pos, du, dv) = p.approx_derivatives(smp[0], smp[1]);
                worst.0 = worst
                    .0
                    .max((pos - DVec3::new(smp[2], smp[3], smp[4])).length() / d);
                worst.1 = worst.1.max(
                    ((du - DVec3::new(smp[5], smp[6], smp[7])).length()
                        + (dv - DVec3::new(smp[8], smp[9], smp[10])).length())
                        / d,
                );
            }
        }
    }
    eprintln!(
        "tagged shapes, OSD EvaluateBasis vs ours: position {:.1e}·diag, derivatives {:.1e}·diag",
        worst.0, worst.1
    );
    assert!(worst.0 < 1e-12 && worst.1 < 1e-12, "{worst:?}");
}

#[test]
fn tagged_non_quad_cages_refine_their_features_as_opensubdiv_does() {
    // Our sharp Catmull–Clark step (sharp edges' halves sharp, sharp vertices kept, holes' children holes)
    // folded into W, against Far's uniform level 1 with the same tags then isolation 0. Numberings differ:
    // match patches geometrically up to a rotation of the corners.
    for (name, rel) in [
        ("catmark_hole_test3_r1", "opensubdiv/catmark_hole_test3.obj"),
        ("pyramid_creased_r1", "fixture:pyramid_creased.obj"),
    ] {
        let fx = read_fixture(name);
        let cage = load(rel);
        let cs = GregoryStencils::from_cage(&cage, Tangents::OpenSubdiv).unwrap();
        assert!(cs.note.as_deref().unwrap_or("").contains("refined once"));
        let ours = cs.stencils.patches_f64(&cage.mesh.positions).unwrap();
        let theirs: Vec<&[DVec3; 20]> = (0..fx.types.len())
            .filter(|&f| fx.types[f] != 2)
            .map(|f| &fx.points[f])
            .collect();
        assert_eq!(ours.len(), theirs.len(), "{name}: patch count");
        let worst = worst_matched_patch(name, &ours, &theirs) / diag(&cage.mesh.positions);
        eprintln!(
            "{name}: sharp CC step + iso 0 vs OpenSubdiv: max {worst:.1e}·diag over {} patches",
            ours.len()
        );
        assert!(worst <= 1e-12, "{name}: {worst:e}");
    }
}

/// Per shared edge of a quad cage's patches: (sharp, max position gap, max normal angle in degrees, the
/// edge touches a sharp vertex, a corner or a dart).
fn edge_figures(cage: &Cage, n: usize) -> Vec<(bool, f64, f64, bool)> {
    let s = GregoryStencils::from_cage(cage, Tangents::OpenSubdiv)
        .unwrap()
        .stencils;
    let patches = s.patches_f64(&cage.mesh.positions).unwrap();
    let m = MeshMatrix::from_mesh(&cage.mesh);
    let features = Features::from_tags(&m, &cage.tags).unwrap();
    let he_edge = m.half_edge_edge();
    let entry = m.corner_entries();
    let twin = twin_corners(&m);
    let cv = m.corner_vertex();
    // Vertices with exactly one sharp edge (darts) or sharp themselves.
    let mut sharp_count = vec![0u32; m.n_verts()];
    for e in 0..m.n_edges() {
        if features.sharp_edge[e] {
            for v in m.edge_vertices(e) {
                sharp_count[v as usize] += 1;
            }
        }
    }
    for (e, u) in m.edge_uses().iter().enumerate() {
        if u.faces() == 1 {
            for v in m.edge_vertices(e) {
                sharp_count[v as usize] += 1;
            }
        }
    }
    // Darts, sharp vertices and corners (three or more sharp edges): OpenSubdiv's sharp corner points are
    // an approximation ("pending future investigation", GregoryConverter), not G1 across the span.
    let special = |v: u32| {
        let n = sharp_count[v as usize];
        features.sharp_vertex[v as usize] || n == 1 || n >= 3
    };
    let patch_of: std::collections::HashMap<u32, usize> = s
        .patch_face
        .iter()
        .enumerate()
        .map(|(k, &f)| (f, k))
        .collect();
    let mut out = Vec::new();
    for c in 0..m.n_corners() {
        let t = twin[c];
        if t == u32::MAX || (t as usize) < c {
            continue;
        }
        let (Some(&pa), Some(&pb)) = (patch_of.get(&((c / 4) as u32)), patch_of.get(&(t / 4)))
        else {
            continue;
        };
        let sharp = features.sharp_edge[he_edge[entry[c] as usize] as usize];
        let touches = special(cv[c]) || special(cv[t as usize]);
        let (mut gap, mut ang) = (0.0f64, 0.0f64);
        for k in 0..=n {
            let x = k as f64 / n as f64;
            let (ua, va) = edge_uv(c % 4, x);
            let (ub, vb) = edge_uv(t as usize % 4, 1.0 - x);
            let (p, su, sv) = patches[pa].eval(ua, va);
            let q = patches[pb].eval(ub, vb).0;
            gap = gap.max((p - q).length());
            // Where S_u ∥ S_v at a corner there is no tangent plane to compare.
            if (k == 0 || k == n) && su.cross(sv).length() <= 1e-10 * su.length() * sv.length() {
                continue;
            }
            ang =
                ang.max(angle(patches[pa].normal(ua, va), patches[pb].normal(ub, vb)).to_degrees());
        }
        out.push((sharp, gap, ang, touches));
    }
    out
}

#[test]
fn creases_are_c0_with_a_fold_and_smooth_edges_stay_g1() {
    for rel in [
        "opensubdiv/catmark_inf_crease0.obj",
        "opensubdiv/catmark_inf_crease1.obj",
        "fixture:quads_dart.obj",
    ] {
        let cage = load(rel);
        let d = diag(&cage.mesh.positions);
        let figs = edge_figures(&cage, 16);
        let sharp: Vec<_> = figs.iter().filter(|f| f.0).collect();
        let smooth: Vec<_> = figs.iter().filter(|f| !f.0 && !f.3).collect();
        let near_special = figs
            .iter()
            .filter(|f| !f.0 && f.3)
            .map(|f| f.2)
            .fold(0.0, f64::max);
        let max_gap = figs.iter().map(|f| f.1).fold(0.0, f64::max) / d;
        let fold = sharp.iter().map(|f| f.2).fold(0.0, f64::max);
        let g1 = smooth.iter().map(|f| f.2).fold(0.0, f64::max);
        eprintln!(
            "{rel}: {} sharp / {} smooth shared edges: gap {max_gap:.1e}·diag, largest fold {fold:.1}°, \
             largest smooth-edge normal jump {g1:.1e}° ({near_special:.2}° on edges at darts and sharp vertices)",
            sharp.len(),
            smooth.len()
        );
        assert!(!sharp.is_empty() && !smooth.is_empty());
        assert!(max_gap < 1e-12, "{rel}: a shared edge cracks ({max_gap:e})");
        assert!(fold > 5.0, "{rel}: no crease folds the surface ({fold}°)");
        // Gregory patches are G1 across smooth edges (the ACC-2 construction), to rounding.
        assert!(g1 < 1e-4, "{rel}: a smooth edge jumps {g1}°");
    }
}

#[test]
fn an_untagged_cage_builds_the_same_stencils_either_way() {
    for name in [
        "catmark_cube",
        "catmark_torus",
        "catmark_gregory_test6",
        "catmark_tent",
        "catmark_nonquads",
    ] {
        let cage = load(&format!("opensubdiv/{name}.obj"));
        assert!(cage.tags.is_plain(), "{name}");
        let a = GregoryStencils::from_cage(&cage, Tangents::OpenSubdiv).unwrap();
        let b = GregoryStencils::from_mesh(&cage.mesh, Tangents::OpenSubdiv).unwrap();
        assert_eq!(a.stencils.w.col, b.stencils.w.col, "{name}");
        assert_eq!(a.stencils.w.val, b.stencils.w.val, "{name}");
        assert_eq!(a.stencils.patch_points, b.stencils.patch_points, "{name}");
        // And with explicit features that say nothing, the general path gives the same bits.
        if (0..cage.mesh.n_faces()).all(|f| cage.mesh.face(f).len() == 4) {
            let m = MeshMatrix::from_mesh(&cage.mesh);
            let c = GregoryStencils::with_features(&m, &Features::none(&m), Tangents::OpenSubdiv)
                .unwrap();
            assert_eq!(c.w.val, b.stencils.w.val, "{name}");
            assert_eq!(c.regular, b.stencils.regular, "{name}");
        }
    }
}

#[test]
fn a_semi_sharp_feature_that_would_refine_past_the_limit_is_refused_before_any_work() {
    // A 64×64 grid with one crease of sharpness 9.5: ten uniform levels would make 4096·4⁹ ≈ 10⁹ patches.
    let mut text = grid_obj(64);
    text += "t crease 2/1/0 70 71 9.5\n";
    let cage = parse_obj_cage(&text, "grid.obj").unwrap();
    let t0 = std::time::Instant::now();
    let err = GregoryStencils::from_cage(&cage, Tangents::OpenSubdiv)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("t crease 70 71 9.5") && err.contains("10 levels") && err.contains("limit"),
        "{err}"
    );
    assert!(t0.elapsed().as_secs_f64() < 5.0, "refused only after work");
    // Sharpness 2 on the same grid is fine: 2 levels.
    let ok = parse_obj_cage(&text.replace(" 9.5\n", " 2\n"), "grid.obj").unwrap();
    let cs = GregoryStencils::from_cage(&ok, Tangents::OpenSubdiv).unwrap();
    assert_eq!(
        (cs.levels, cs.stencils.patch_points.len()),
        (2, 64 * 64 * 16)
    );
    assert!(cs.note.unwrap().contains("semi-sharp"));
}

#[test]
fn bad_tags_are_clear_errors_naming_the_line() {
    let quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
    for (tag, needles) in [
        (
            "t crease 2/1/0 0 2 10",
            vec!["line 6", "crease 0 2", "not an edge"],
        ),
        ("t crease 2/1/0 0 9 10", vec!["line 6", "out of range"]),
        ("t crease 2/1/0 0 1 nan", vec!["line 6", "not a finite"]),
        ("t crease 2/1/0 0 1", vec!["line 6", "announce 3 arguments"]),
        ("t corner 1/1/0 -1 10", vec!["line 6", "out of range"]),
        (
            "t hole 1/0/0 3",
            vec!["line 6", "hole 3", "face out of range"],
        ),
        (
            "t interpolateboundary 1/0/0 7",
            vec!["line 6", "unknown value 7"],
        ),
        (
            "t vertexedit 1/0/0 0",
            vec!["line 6", "vertexedit", "not supported"],
        ),
        (
            "t sparkle 0/0/0",
            vec!["line 6", "t sparkle", "unknown tag"],
        ),
        ("t crease x/1/0 0 1 10", vec!["line 6", "argument counts"]),
        ("t creasemethod 0/0/1 zigzag", vec!["line 6", "zigzag"]),
    ] {
        let err = parse_obj_cage(&format!("{quad}{tag}\n"), "tags.obj")
            .unwrap_err()
            .to_string();
        for n in needles {
            assert!(err.contains(n), "{tag}: '{err}' lacks '{n}'");
        }
        assert!(err.starts_with("tags.obj"), "{err}");
    }
    // Every face a hole: nothing to draw, said so.
    let c = parse_obj_cage(&format!("{quad}t hole 1/0/0 0\n"), "h.obj").unwrap();
    let err = GregoryStencils::from_cage(&c, Tangents::OpenSubdiv)
        .unwrap_err()
        .to_string();
    assert!(err.contains("every face of the cage is a hole"), "{err}");
    // Tags that change nothing here are reported, not dropped.
    let c = parse_obj_cage(
        &format!("{quad}t facevaryinginterpolateboundary 1/0/0 1\n"),
        "fv.obj",
    )
    .unwrap();
    let cs = GregoryStencils::from_cage(&c, Tangents::OpenSubdiv).unwrap();
    assert!(cs
        .note
        .as_deref()
        .unwrap_or("")
        .contains("facevaryinginterpolateboundary"));
}

#[test]
fn the_cli_refuses_an_unknown_tag_and_draws_tagged_cages() {
    let dir = std::env::temp_dir().join(format!("gregvox-creases-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("o.obj");
    let run = |input: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_gregvox"))
            .args(["tessellate", input, "--level", "2", "--out"])
            .arg(&out)
            .output()
            .unwrap()
    };
    let edit = dir.join("edit.obj");
    let cube = std::fs::read_to_string(model("opensubdiv/catmark_cube.obj")).unwrap();
    std::fs::write(&edit, format!("{cube}t vertexedit 1/0/0 0\n")).unwrap();
    let r = run(edit.to_str().unwrap());
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success(), "{stderr}");
    assert!(
        stderr.contains("edit.obj") && stderr.contains("t vertexedit"),
        "{stderr}"
    );
    assert!(!out.exists(), "nothing is written on an error");
    let faces_of = |input: &str| {
        let r = run(input);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        let text = std::fs::read_to_string(&out).unwrap();
        text.lines().filter(|l| l.starts_with("f ")).count()
    };
    // A hole: 5 of the cube's 6 faces drawn.
    let holed = faces_of(&model("opensubdiv/catmark_hole_test1.obj"));
    let whole = faces_of(&model("opensubdiv/catmark_cube.obj"));
    assert!(
        whole > 0 && 6 * holed == 5 * whole,
        "{holed} of {whole} faces"
    );
    // A semi-sharp crease (2.0): the cube refined twice, 16 patches per face.
    let creased = faces_of(&model("opensubdiv/catmark_cube_creases0.obj"));
    assert_eq!(creased, 16 * whole);
    std::fs::remove_dir_all(&dir).ok();
}
