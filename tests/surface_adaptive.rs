//! Feature-adaptive refinement (`surface::adaptive`): the surface is the uniform refinement's, point for
//! point, with patches only as deep as the features need; its quadtrees; its worst cases.
#[path = "surface_common.rs"]
mod common;
use common::*;
use gregvox::mesh::{load_obj_cage, parse_obj_cage, Cage};
use gregvox::surface::adaptive::{AdaptiveStencils, Node};
use gregvox::surface::{GregoryStencils, LimitEvaluator, Tangents};

/// Every OpenSubdiv regression shape in the models folder, with the isolation levels to try.
fn shapes() -> Vec<(String, Cage)> {
    let mut names: Vec<String> = std::fs::read_dir(model("opensubdiv"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".obj"))
        .collect();
    names.sort();
    names
        .into_iter()
        .map(|n| {
            let cage = load_obj_cage(model(&format!("opensubdiv/{n}"))).unwrap();
            (n, cage)
        })
        .collect()
}

/// Random (ptex face, u, v) and the face edges and corners (where patches of different depths meet).
fn samples(faces: usize, n: usize, seed: u64) -> Vec<(u32, f64, f64)> {
    let mut rng = Rng(seed);
    let mut at = Vec::new();
    for _ in 0..n {
        let f = ((rng.uniform() * faces as f64) as usize).min(faces - 1) as u32;
        at.push((f, rng.uniform(), rng.uniform()));
    }
    for f in 0..faces as u32 {
        for t in [0.0, 0.25, 0.5, 0.625, 1.0] {
            at.extend([(f, t, 0.0), (f, 1.0, t), (f, t, 1.0), (f, 0.0, t)]);
        }
    }
    at
}

#[test]
fn the_adaptive_surface_is_the_uniform_refinements_point_for_point() {
    let mut worst = 0.0f64;
    let mut compared = 0;
    for (name, cage) in shapes() {
        for iso in [None, Some(1), Some(2)] {
            let mut cage = cage.clone();
            if let Some(l) = iso {
                // Below what the cage needs: refused by both (tested elsewhere).
                cage.tags.isolation = Some(l);
            }
            let Ok(cs) = GregoryStencils::from_cage(&cage, Tangents::OpenSubdiv) else {
                continue;
            };
            let uniform = LimitEvaluator::from_stencils(&cage, &cs).unwrap();
            let adaptive = LimitEvaluator::new(&cage, Tangents::OpenSubdiv).unwrap();
            assert_eq!(adaptive.ptex_faces(), uniform.ptex_faces(), "{name}");
            let at: Vec<_> = samples(uniform.ptex_faces(), 400, 7)
                .into_iter()
                .filter(|&(f, u, v)| uniform.evaluate(&[(f, u, v)]).is_ok())
                .collect();
            let (a, b) = (
                adaptive.evaluate(&at).unwrap(),
                uniform.evaluate(&at).unwrap(),
            );
            let d = diag(&cage.mesh.positions);
            for (k, (x, y)) in a.iter().zip(&b).enumerate() {
                let e = (x.position - y.position).length() / d;
                let ed = ((x.du - y.du).length() + (x.dv - y.dv).length()) / d;
                assert!(
                    e < 1e-13 && ed < 1e-10,
                    "{name} iso {iso:?}: sample {:?}: {e:e} {ed:e}",
                    at[k]
                );
                worst = worst.max(e);
            }
            if cage.uv.is_some() {
                let (ua, ub) = (
                    adaptive.evaluate_uv(&at).unwrap(),
                    uniform.evaluate_uv(&at).unwrap(),
                );
                for (x, y) in ua.iter().zip(&ub) {
                    assert!(
                        (x[0] - y[0]).abs() + (x[1] - y[1]).abs() < 1e-12,
                        "{name} iso {iso:?} uv"
                    );
                }
            }
            compared += 1;
        }
    }
    eprintln!("{compared} cages: adaptive vs uniform ≤ {worst:.1e}·diag");
    assert!(compared > 60, "{compared}");
}

/// One OpenSubdiv sample of a `.ptex` fixture: (face, u, v), P, Du, Dv, whether a Gregory basis patch.
struct Sample {
    at: (u32, f64, f64),
    p: glam::DVec3,
    du: glam::DVec3,
    dv: glam::DVec3,
    gregory: bool,
}

fn read_ptex(name: &str) -> Vec<Sample> {
    read_records(name, "ptex", 13)
        .iter()
        .map(|r| Sample {
            at: (r[0] as u32, r[1], r[2]),
            p: glam::DVec3::new(r[3], r[4], r[5]),
            du: glam::DVec3::new(r[6], r[7], r[8]),
            dv: glam::DVec3::new(r[9], r[10], r[11]),
            gregory: r[12] != 0.0,
        })
        .collect()
}

#[test]
fn cages_past_the_uniform_limit_are_opensubdivs_adaptive_surface() {
    // OpenSubdiv's catmark_car (314 creases of sharpness 6: RefineAdaptive(6)) and a 64² grid with a crease
    // polyline of 9.5 and a corner of 7.25 (RefineAdaptive(10)): uniform refinement would make 6.4 M and
    // 4·10⁹ patches and refuses both; feature-adaptive refinement builds them.
    for (name, path, fixtures, levels) in [
        (
            "catmark_car",
            model("opensubdiv/catmark_car.obj"),
            &["catmark_car"][..],
            6,
        ),
        (
            "grid64_crease9",
            format!(
                "{}/tests/fixtures/surface/cages/grid64_crease9.obj",
                env!("CARGO_MANIFEST_DIR")
            ),
            &["grid64_crease9", "grid64_crease9_near"][..],
            10,
        ),
    ] {
        let cage = load_obj_cage(&path).unwrap();
        let uniform = GregoryStencils::from_cage(&cage, Tangents::OpenSubdiv)
            .unwrap_err()
            .to_string();
        assert!(uniform.contains("limit"), "{uniform}");
        let t0 = std::time::Instant::now();
        let a = AdaptiveStencils::from_cage(&cage, Tangents::OpenSubdiv).unwrap();
        let build = t0.elapsed().as_secs_f64();
        assert_eq!(a.levels, levels);
        assert_eq!(*a.depth.iter().max().unwrap() as u32, levels, "{name}");
        let e = LimitEvaluator::from_adaptive(&cage, &a).unwrap();
        let d = diag(&cage.mesh.positions);
        let (mut pos, mut der, mut n, mut n_greg) = (0.0f64, 0.0f64, 0, 0);
        for fixture in fixtures {
            let samples = read_ptex(fixture);
            let at: Vec<_> = samples.iter().map(|s| s.at).collect();
            let ours = e.evaluate(&at).unwrap();
            for (s, o) in samples.iter().zip(&ours) {
                pos = pos.max((o.position - s.p).length() / d);
                if s.gregory {
                    n_greg += 1;
                } else {
                    der = der.max(((o.du - s.du).length() + (o.dv - s.dv).length()) / d);
                }
            }
            n += samples.len();
        }
        eprintln!(
            "{name:16} L = {levels:2}: {} patches (faces split per level {:?}), built in {build:.2} s; {n} \
             samples ({n_greg} on Gregory caps): position {pos:.1e}·diag, B-spline derivatives {der:.1e}·diag",
            a.stencils.patch_points.len(),
            a.split_per_level,
        );
        assert!(pos <= 1e-12 && der <= 1e-10, "{name}: {pos:e} {der:e}");
        assert!(
            n_greg > 0 || name == "grid64_crease9",
            "{name}: no sample on a deep cap"
        );
    }
}

#[test]
fn patches_are_only_as_deep_as_the_features_need() {
    // catmark_cubes_semisharp at L = 5: the uniform refinement's 4⁵ patches per face against the adaptive
    // count, and the quadtree: every patch is reached from its cage face at its own depth.
    let cage = load_obj_cage(model("opensubdiv/catmark_cubes_semisharp.obj")).unwrap();
    let a = AdaptiveStencils::from_cage(&cage, Tangents::OpenSubdiv).unwrap();
    let u = GregoryStencils::from_cage(&cage, Tangents::OpenSubdiv).unwrap();
    assert_eq!(a.levels, u.levels);
    let (na, nu) = (a.stencils.patch_points.len(), u.stencils.patch_points.len());
    eprintln!(
        "catmark_cubes_semisharp L = {}: {na} adaptive patches, {nu} uniform",
        a.levels
    );
    assert!(na * 8 < nu, "{na} vs {nu}");
    assert!(a.stencils.w.n_rows < u.stencils.w.n_rows / 4);
    // Walk the trees: each patch once, at the depth it records, under the cage face it records.
    let mut seen = vec![false; na];
    let mut stack: Vec<(u32, u8, u32)> =
        (0..cage.mesh.n_faces() as u32).map(|f| (f, 0, f)).collect();
    while let Some((node, depth, face)) = stack.pop() {
        match a.tree.nodes[node as usize] {
            Node::Patch(k) => {
                assert!(!std::mem::replace(&mut seen[k as usize], true));
                assert_eq!(
                    (a.depth[k as usize], a.stencils.patch_face[k as usize]),
                    (depth, face)
                );
            }
            Node::Split { first } => {
                let n = if depth == 0 {
                    cage.mesh.face(face as usize).len() as u32
                } else {
                    4
                };
                stack.extend((first..first + n).map(|c| (c, depth + 1, face)));
            }
            Node::Hole => {}
        }
    }
    assert!(seen.iter().all(|&s| s));
    // Regular (B-spline) patches everywhere above the isolation level.
    for (k, &d) in a.depth.iter().enumerate() {
        if (d as u32) < a.levels {
            assert!(
                a.stencils.regular[k],
                "patch {k} at depth {d} is a Gregory cap"
            );
        }
    }
}

#[test]
fn many_deep_features_are_refused_before_the_level_that_would_pass_the_limit() {
    // The attacking input: a 64² grid whose every interior edge is a crease of 9.5 (10 levels everywhere:
    // ~4·10⁹ patches). Refused by name, quickly.
    let n = 64;
    let mut text = grid_obj(n);
    for j in 1..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            text += &format!("t crease 2/1/0 {a} {} 9.5\n", a + 1);
        }
    }
    let cage = parse_obj_cage(&text, "grid.obj").unwrap();
    let t0 = std::time::Instant::now();
    let err = AdaptiveStencils::from_cage(&cage, Tangents::OpenSubdiv)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("feature-adaptive") && err.contains("limit"),
        "{err}"
    );
    // A memory guard, not a speed test: it must stop before the level that would pass the limit.
    assert!(
        t0.elapsed().as_secs_f64() < 60.0,
        "refused only after {:?}",
        t0.elapsed()
    );
    // And through the evaluator and the CLI's path: the same message.
    let e = LimitEvaluator::new(&cage, Tangents::OpenSubdiv)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("feature-adaptive"), "{e}");
}

#[test]
fn gregvox_evaluate_takes_a_cage_past_the_uniform_limit() {
    let dir = std::env::temp_dir().join(format!("gregvox-adaptive-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (fuv, out) = (dir.join("fuv.npy"), dir.join("p.npz"));
    let samples = read_ptex("catmark_car");
    let rows: Vec<[f64; 3]> = samples[..100]
        .iter()
        .map(|s| [s.at.0 as f64, s.at.1, s.at.2])
        .collect();
    write_npy_f64(&fuv, &rows);
    let car = model("opensubdiv/catmark_car.obj");
    let gregvox = |args: &[&std::ffi::OsStr]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_gregvox"))
            .args(args)
            .output()
            .unwrap()
    };
    let r = gregvox(&[
        "evaluate".as_ref(),
        car.as_ref(),
        "--at".as_ref(),
        fuv.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let p = npz_f64(&std::fs::read(&out).unwrap(), "position").unwrap();
    let d = diag(&load_obj_cage(&car).unwrap().mesh.positions);
    for (k, s) in samples[..100].iter().enumerate() {
        let q = glam::DVec3::new(p[3 * k], p[3 * k + 1], p[3 * k + 2]);
        assert!((q - s.p).length() < 1e-12 * d, "sample {k}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_cage_past_the_uniform_limit_tessellates_per_ptex_face_crack_free() {
    // The car: 136 k patches of depths 0–6 side by side. One grid per ptex face, evaluated through the
    // quadtrees: the welded mesh has the cage's own topology (its boundary edges × the level, its
    // components and Euler characteristic; no crack, no non-manifold or flipped edge), and every grid vertex
    // is the limit surface at its (face, u, v).
    let dir = std::env::temp_dir().join(format!("gregvox-adaptive-tess-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let car = model("opensubdiv/catmark_car.obj");
    let level = 4;
    let tess = |out: &std::path::Path, extra: &[&str]| {
        let r = std::process::Command::new(env!("CARGO_BIN_EXE_gregvox"))
            .arg("tessellate")
            .arg(&car)
            .args(["--level", &level.to_string(), "--out"])
            .arg(out)
            .args(extra)
            .output()
            .unwrap();
        (
            r.status.success(),
            String::from_utf8_lossy(&r.stderr).into_owned(),
        )
    };
    let welded = dir.join("car.obj");
    let (ok, err) = tess(&welded, &[]);
    assert!(ok && err.contains("per ptex face"), "{err}");
    let cage = load_obj_cage(&car).unwrap();
    let before = gregvox::mesh::MeshMatrix::from_mesh(&cage.mesh).report();
    let after =
        gregvox::mesh::MeshMatrix::from_mesh(&gregvox::mesh::load_obj(&welded).unwrap()).report();
    assert_eq!(after.boundary_edges, level * before.boundary_edges);
    assert_eq!((after.non_manifold_edges, after.inconsistent_edges), (0, 0));
    assert_eq!(after.euler_characteristic, before.euler_characteristic);
    assert!(std::fs::read_to_string(&welded).unwrap().contains("\nvt "));
    // The grids, unwelded: vertex (i, j) of grid g is the surface at (g, i/L, j/L).
    let grids = dir.join("grids.obj");
    let (ok, err) = tess(&grids, &["--no-weld"]);
    assert!(ok, "{err}");
    let v: Vec<glam::DVec3> = std::fs::read_to_string(&grids)
        .unwrap()
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let x: Vec<f64> = l.split_whitespace().map(|t| t.parse().unwrap()).collect();
            glam::DVec3::new(x[0], x[1], x[2])
        })
        .collect();
    let n = (level + 1) * (level + 1);
    assert_eq!(v.len(), cage.mesh.n_faces() * n);
    let e = LimitEvaluator::new(&cage, Tangents::OpenSubdiv).unwrap();
    let d = diag(&cage.mesh.positions);
    for g in (0..cage.mesh.n_faces()).step_by(37) {
        for k in [0, 7, n - 1] {
            let (i, j) = (k % (level + 1), k / (level + 1));
            let at = (g as u32, i as f64 / level as f64, j as f64 / level as f64);
            let p = e.evaluate(&[at]).unwrap()[0].position;
            assert!(
                (v[g * n + k] - p).length() < 1e-6 * d,
                "grid {g} vertex {k}"
            );
        }
    }
    // Deformed on the device (the ptex layout): the welded mesh still has the cage's topology.
    let twisted = dir.join("twisted.obj");
    let (ok, err) = tess(&twisted, &["--deform", "twist:0.5"]);
    assert!(ok, "{err}");
    let t =
        gregvox::mesh::MeshMatrix::from_mesh(&gregvox::mesh::load_obj(&twisted).unwrap()).report();
    assert_eq!(
        (
            t.boundary_edges,
            t.euler_characteristic,
            t.non_manifold_edges
        ),
        (after.boundary_edges, after.euler_characteristic, 0)
    );
    // What needs the uniform layout says so.
    let (ok, err) = tess(&dir.join("a.obj"), &["--adaptive", "8"]);
    assert!(!ok && err.contains("uniform patch layout"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn ptex_grids_weld_like_the_uniform_tessellation_on_quads_n_gons_and_holes() {
    // --isolation 10 puts these cages past the uniform limit (ptex grids, level 4 a cage edge); the
    // uniform path at --isolation 1 and level 2 a refined patch has 4 segments a cage edge too. The welded
    // meshes must have the same vertices, triangles, boundary edges and Euler characteristic: the n-gons'
    // spokes and centres, the cage's edges and vertices and the holes' rims all weld as the uniform
    // layout's shared rows make them weld.
    let dir = std::env::temp_dir().join(format!("gregvox-ptex-weld-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for name in ["catmark_cube", "catmark_nonquads", "catmark_hole_test3"] {
        let cage = model(&format!("opensubdiv/{name}.obj"));
        let topology = |iso: &str, level: &str| {
            let out = dir.join(format!("{name}_{iso}.obj"));
            let r = std::process::Command::new(env!("CARGO_BIN_EXE_gregvox"))
                .arg("tessellate")
                .arg(&cage)
                .args(["--isolation", iso, "--level", level, "--out"])
                .arg(&out)
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&r.stderr).into_owned();
            assert!(r.status.success(), "{err}");
            let mesh = gregvox::mesh::load_obj(&out).unwrap();
            let rep = gregvox::mesh::MeshMatrix::from_mesh(&mesh).report();
            let counts = (
                mesh.positions.len(),
                mesh.n_faces(),
                rep.boundary_edges,
                rep.non_manifold_edges + rep.inconsistent_edges,
                rep.euler_characteristic,
            );
            (err.contains("per ptex face"), counts)
        };
        let (ptex, a) = topology("10", "4");
        let (uniform, b) = topology("1", "2");
        assert!(ptex && !uniform, "{name}");
        assert_eq!(a, b, "{name}");
        assert_eq!(a.3, 0, "{name}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_huge_polygon_past_the_uniform_limit_is_refused_by_its_valence_before_any_work() {
    // A 100-gon at --isolation 10: past the uniform limit, so tessellate takes the ptex-grid path; its
    // centre would have valence 100, past what Gregory patches support. Refused naming the face.
    let dir = std::env::temp_dir().join(format!("gregvox-ptex-ngon-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let n = 100;
    let mut text = String::new();
    for k in 0..n {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        text += &format!("v {} {} 0\n", a.cos(), a.sin());
    }
    text += "f";
    for k in 1..=n {
        text += &format!(" {k}");
    }
    text += "\n";
    let (cage, out) = (dir.join("ngon.obj"), dir.join("out.obj"));
    std::fs::write(&cage, text).unwrap();
    let r = std::process::Command::new(env!("CARGO_BIN_EXE_gregvox"))
        .arg("tessellate")
        .arg(&cage)
        .args(["--isolation", "10", "--level", "2", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        !r.status.success() && err.contains("100 vertices") && err.contains("valence"),
        "{err}"
    );
    assert!(!out.exists());
    std::fs::remove_dir_all(&dir).ok();
}
