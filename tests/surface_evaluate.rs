//! The limit surface at arbitrary (ptex face, u, v) against OpenSubdiv's `Far::PatchMap` + `EvaluateBasis`
//! (fixtures `*.ptex` from tests/oracle/osd_gregory.cpp --ptex: RefineAdaptive(0) on all-quad cages, (1) on
//! cages with other faces), the exactness of the derivatives, bad rows, and `gregvox evaluate`.
#[path = "surface_common.rs"]
mod common;
use common::*;
use glam::DVec3;
use gregvox::mesh::load_obj_cage;
use gregvox::surface::{LimitEvaluator, Tangents};

/// One OpenSubdiv sample: (face, u, v), P, Du, Dv, whether its patch is a Gregory basis patch.
struct Sample {
    at: (u32, f64, f64),
    p: DVec3,
    du: DVec3,
    dv: DVec3,
    gregory: bool,
}

fn read_ptex(name: &str) -> Vec<Sample> {
    read_records(name, "ptex", 13)
        .iter()
        .map(|r| Sample {
            at: (r[0] as u32, r[1], r[2]),
            p: DVec3::new(r[3], r[4], r[5]),
            du: DVec3::new(r[6], r[7], r[8]),
            dv: DVec3::new(r[9], r[10], r[11]),
            gregory: r[12] != 0.0,
        })
        .collect()
}

const SHAPES: &[(&str, &str)] = &[
    ("catmark_cube", "opensubdiv/catmark_cube.obj"),
    ("catmark_torus", "opensubdiv/catmark_torus.obj"),
    (
        "catmark_gregory_test6",
        "opensubdiv/catmark_gregory_test6.obj",
    ),
    ("catmark_inf_crease0", "opensubdiv/catmark_inf_crease0.obj"),
    ("catmark_edgenone", "opensubdiv/catmark_edgenone.obj"),
    ("catmark_hole_test1", "opensubdiv/catmark_hole_test1.obj"),
    ("catmark_nonquads", "opensubdiv/catmark_nonquads.obj"),
    ("catmark_hole_test3", "opensubdiv/catmark_hole_test3.obj"),
];

#[test]
fn evaluation_at_ptex_parameters_matches_opensubdivs_patch_map() {
    for &(name, rel) in SHAPES {
        let cage = load_obj_cage(model(rel)).unwrap();
        let e = LimitEvaluator::new(&cage, Tangents::OpenSubdiv).unwrap();
        let samples = read_ptex(name);
        let at: Vec<_> = samples.iter().map(|s| s.at).collect();
        let ours = e.evaluate(&at).unwrap();
        let d = diag(&cage.mesh.positions);
        let (mut pos, mut der, mut nrm) = (0.0f64, 0.0f64, 0.0f64);
        let mut n_greg = 0;
        for (s, o) in samples.iter().zip(&ours) {
            pos = pos.max((o.position - s.p).length() / d);
            if s.gregory {
                // OpenSubdiv's Gregory derivatives are an approximation (Q frozen): normals compared.
                n_greg += 1;
                nrm = nrm.max(angle(o.du.cross(o.dv), s.du.cross(s.dv)).to_degrees());
            } else {
                der = der.max(((o.du - s.du).length() + (o.dv - s.dv).length()) / d);
            }
        }
        eprintln!(
            "{name:22} {} samples ({n_greg} on Gregory patches): position {pos:.1e}·diag, B-spline derivatives \
             {der:.1e}·diag, Gregory normals vs OpenSubdiv's approximate ones {nrm:.3}°",
            samples.len()
        );
        assert!(pos <= 1e-12, "{name}: position {pos:e}");
        assert!(der <= 1e-12, "{name}: derivatives {der:e}");
        assert!(nrm <= 5.0, "{name}: normals {nrm}°");
    }
}

#[test]
fn normals_are_the_exact_normals_of_opensubdivs_surface() {
    // The oracle's exact derivatives of OpenSubdiv's own positions (differences of EvaluateBasis on each
    // sample's patch, `--fd`; its Gregory derivatives freeze the rational points and are off by up to a few
    // degrees): our normals within 0.05° of theirs, everywhere the tangent plane is defined (S_u × S_v not
    // vanishing: valence-2 points and degenerate corners have none). The car: its 136 k adaptive patches.
    let mut shapes: Vec<(&str, &str)> = SHAPES.to_vec();
    shapes.push(("catmark_car", "opensubdiv/catmark_car.obj"));
    for (name, rel) in shapes {
        let cage = load_obj_cage(model(rel)).unwrap();
        let e = LimitEvaluator::new(&cage, Tangents::OpenSubdiv).unwrap();
        let samples = read_ptex(name);
        let fd = read_records(name, "fd", 6);
        assert_eq!(fd.len(), samples.len(), "{name}");
        let at: Vec<_> = samples.iter().map(|s| s.at).collect();
        let ours = e.evaluate(&at).unwrap();
        let (mut worst, mut der, mut skipped) = (0.0f64, 0.0f64, 0);
        for (o, f) in ours.iter().zip(&fd) {
            let (du, dv) = (DVec3::new(f[0], f[1], f[2]), DVec3::new(f[3], f[4], f[5]));
            let n = du.cross(dv);
            if n.length() <= 1e-6 * du.length() * dv.length() {
                skipped += 1;
                continue;
            }
            worst = worst.max(angle(o.du.cross(o.dv), n).to_degrees());
            let scale = du.length().max(dv.length());
            der = der.max(((o.du - du).length()).max((o.dv - dv).length()) / scale);
        }
        eprintln!(
            "{name:22} {} samples: normals vs the exact ones {worst:.1e}°, derivatives {der:.1e} (relative); \
             {skipped} without a tangent plane",
            samples.len()
        );
        assert!(worst <= 0.05, "{name}: {worst}°");
        assert!(der <= 1e-6, "{name}: derivatives {der:e}");
        assert!(skipped * 20 < samples.len(), "{name}: {skipped} skipped");
    }
}

#[test]
fn derivatives_are_the_exact_derivatives_of_the_evaluated_positions() {
    // OpenSubdiv's Gregory derivatives freeze the rational points; ours differentiate them too. Central
    // differences of our own positions (step 1e-5) check first and second derivatives, also across the
    // quadrant map of refined quads (catmark_nonquads).
    let h = 1e-5;
    for &(name, rel) in SHAPES {
        let cage = load_obj_cage(model(rel)).unwrap();
        let e = LimitEvaluator::new(&cage, Tangents::OpenSubdiv).unwrap();
        let d = diag(&cage.mesh.positions);
        let mut rng = Rng(0x5eed ^ name.len() as u64);
        let (mut e1, mut e2) = (0.0f64, 0.0f64);
        for _ in 0..200 {
            let f = ((rng.uniform() + 1.0) * 0.5 * e.ptex_faces() as f64) as u32
                % e.ptex_faces() as u32;
            // Away from the parameter border and the quadrant seams, where one-sided patches meet.
            let pick = |r: &mut Rng| {
                let x = 0.02 + 0.46 * (r.uniform() + 1.0) * 0.5;
                if r.uniform() > 0.0 {
                    x
                } else {
                    1.0 - x
                }
            };
            let (u, v) = (pick(&mut rng), pick(&mut rng));
            let q = |du: f64, dv: f64| (f, u + du, v + dv);
            let Ok(s) = e.evaluate(&[q(0.0, 0.0), q(h, 0.0), q(-h, 0.0), q(0.0, h), q(0.0, -h)])
            else {
                continue; // a hole
            };
            let fd_u = (s[1].position - s[2].position) / (2.0 * h);
            let fd_v = (s[3].position - s[4].position) / (2.0 * h);
            e1 = e1.max(((fd_u - s[0].du).length() + (fd_v - s[0].dv).length()) / d);
            let fd_uu = (s[1].du - s[2].du) / (2.0 * h);
            let fd_uv = (s[3].du - s[4].du) / (2.0 * h);
            let fd_vv = (s[3].dv - s[4].dv) / (2.0 * h);
            e2 = e2.max(
                ((fd_uu - s[0].duu).length()
                    + (fd_uv - s[0].duv).length()
                    + (fd_vv - s[0].dvv).length())
                    / d,
            );
        }
        eprintln!("{name:22} |D − finite differences|: first {e1:.1e}·diag, second {e2:.1e}·diag");
        assert!(e1 < 1e-7 && e2 < 1e-5, "{name}: {e1:e} {e2:e}");
    }
}

#[test]
fn bad_rows_are_errors_naming_the_row() {
    let cage = load_obj_cage(model("opensubdiv/catmark_hole_test1.obj")).unwrap();
    let e = LimitEvaluator::new(&cage, Tangents::OpenSubdiv).unwrap();
    for (row, needle) in [
        ((0, 0.5, 0.5), ""),
        ((1, 0.5, 0.5), "hole"),
        ((6, 0.5, 0.5), "no such face"),
        ((0, f64::NAN, 0.5), "[0, 1]"),
        ((0, 0.5, 1.0 + 1e-9), "[0, 1]"),
        ((0, -0.0, 1.0), ""),
    ] {
        let r = e.evaluate(&[(0, 0.5, 0.5), row]);
        if needle.is_empty() {
            assert!(r.is_ok(), "{row:?}: {r:?}");
        } else {
            let msg = r.unwrap_err().to_string();
            assert!(
                msg.contains("row 1") && msg.contains(needle),
                "{row:?}: {msg}"
            );
        }
    }
}

#[test]
fn gregvox_evaluate_writes_the_arrays_and_refuses_bad_rows() {
    let dir = std::env::temp_dir().join(format!("gregvox-evaluate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (fuv, out) = (dir.join("fuv.npy"), dir.join("p.npz"));
    let samples = read_ptex("catmark_nonquads");
    let rows: Vec<[f64; 3]> = samples[..50]
        .iter()
        .map(|s| [s.at.0 as f64, s.at.1, s.at.2])
        .collect();
    write_npy_f64(&fuv, &rows);
    let run = || {
        std::process::Command::new(env!("CARGO_BIN_EXE_gregvox"))
            .arg("evaluate")
            .arg(model("opensubdiv/catmark_nonquads.obj"))
            .arg("--at")
            .arg(&fuv)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap()
    };
    let r = run();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    // The .npz holds stored .npy entries: find "position.npy" and read its first row.
    let z = std::fs::read(&out).unwrap();
    for name in ["position", "du", "dv", "duu", "duv", "dvv"] {
        assert!(
            z.windows(name.len() + 4)
                .any(|w| w == format!("{name}.npy").as_bytes()),
            "{name} missing"
        );
    }
    let at = z.windows(12).position(|w| w == b"position.npy").unwrap();
    let magic = at + z[at..].windows(6).position(|w| w == b"\x93NUMPY").unwrap();
    let hlen = u16::from_le_bytes([z[magic + 8], z[magic + 9]]) as usize;
    let data = magic + 10 + hlen;
    let x: Vec<f64> = (0..3)
        .map(|k| f64::from_le_bytes(z[data + 8 * k..data + 8 * k + 8].try_into().unwrap()))
        .collect();
    assert!(
        (DVec3::from_slice(&x) - samples[0].p).length() < 1e-12,
        "{x:?}"
    );
    // A bad row: one error line naming the file and the row, nothing written.
    std::fs::remove_file(&out).unwrap();
    let mut bad = rows.clone();
    bad[7] = [3.0, 0.5, 2.0];
    write_npy_f64(&fuv, &bad);
    let r = run();
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        !r.status.success() && err.contains("row 7") && err.contains("fuv.npy"),
        "{err}"
    );
    assert!(!out.exists());
    bad[7] = [2.5, 0.5, 0.5];
    write_npy_f64(&fuv, &bad);
    let err = String::from_utf8_lossy(&run().stderr).to_string();
    assert!(
        err.contains("row 7") && err.contains("whole number"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// OpenSubdiv shapes with semi-sharp creases or corners (uniform and Chaikin creasing, 0.1 ≤ s ≤ 5).
const SEMI_SHARP: &[&str] = &[
    "catmark_cube_creases0",
    "catmark_cube_creases1",
    "catmark_cube_creases2",
    "catmark_cubes_semisharp",
    "catmark_cubes_infsharp",
    "catmark_chaikin0",
    "catmark_chaikin1",
    "catmark_chaikin2",
    "catmark_tent_creases0",
    "catmark_tent_creases1",
    "catmark_pyramid_creases0",
    "catmark_pyramid_creases1",
    "catmark_pyramid_creases2",
    "catmark_torus_creases0",
    "catmark_torus_creases1",
    "catmark_dart_edgeonly",
    "catmark_dart_edgecorner",
    "catmark_val2_interior",
    "catmark_cube_corner0",
    "catmark_cube_corner1",
    "catmark_cube_corner2",
    "catmark_cube_corner3",
    "catmark_gregory_test3",
    "catmark_edgeonly",
];

#[test]
fn semi_sharp_cages_are_opensubdivs_adaptive_surface() {
    // OpenSubdiv isolates semi-sharp features adaptively to level ⌈s⌉ (RefineAdaptive); gregvox refines
    // the whole cage ⌈s⌉ times with the same crease rules. The limit surfaces agree wherever the patches
    // are exact B-splines or Gregory caps at that level, which covers every shape here.
    let mut worst = 0.0f64;
    for name in SEMI_SHARP {
        let cage = load_obj_cage(model(&format!("opensubdiv/{name}.obj"))).unwrap();
        let cs = gregvox::surface::GregoryStencils::from_cage(&cage, Tangents::OpenSubdiv).unwrap();
        let e = LimitEvaluator::from_stencils(&cage, &cs).unwrap();
        let samples = read_ptex(name);
        let at: Vec<_> = samples.iter().map(|s| s.at).collect();
        let ours = e.evaluate(&at).unwrap();
        let d = diag(&cage.mesh.positions);
        // OpenSubdiv 3.5 scales the derivatives of patches under a non-quad face by 2^depth where the
        // sub-face's own parametrization gives 2^(depth − 1) (its depth 1 is the sub-face itself): from
        // depth 2 on its du, dv are twice the derivatives of its own positions. Ours are those derivatives
        // (checked by central differences below and in derivatives_are_…), so there we expect exactly 2×.
        let subface: Vec<bool> = (0..cage.mesh.n_faces())
            .flat_map(|f| {
                let n = cage.mesh.face(f).len();
                vec![n != 4; if n == 4 { 1 } else { n }]
            })
            .collect();
        let (mut pos, mut der, mut n_doubled) = (0.0f64, 0.0f64, 0);
        for (s, o) in samples.iter().zip(&ours) {
            pos = pos.max((o.position - s.p).length() / d);
            let k = if subface[s.at.0 as usize] && cs.levels >= 2 {
                n_doubled += 1;
                2.0
            } else {
                1.0
            };
            if !s.gregory {
                der = der.max(((o.du * k - s.du).length() + (o.dv * k - s.dv).length()) / d);
            }
        }
        if n_doubled > 0 {
            // The factor is OpenSubdiv's: our derivatives are those of the (shared) positions.
            let (f, u, v) = samples
                .iter()
                .find(|s| subface[s.at.0 as usize])
                .unwrap()
                .at;
            let (u, v, h) = (u.clamp(1e-3, 0.999), v.clamp(1e-3, 0.999), 1e-6);
            let p = e
                .evaluate(&[(f, u, v), (f, u + h, v), (f, u - h, v)])
                .unwrap();
            let fd = (p[1].position - p[2].position) / (2.0 * h);
            assert!(
                (fd - p[0].du).length() < 1e-6 * d,
                "{name}: {fd} vs {}",
                p[0].du
            );
        }
        eprintln!(
            "{name:26} L = {}, {:6} patches: position {pos:.1e}·diag, B-spline derivatives {der:.1e}·diag{}",
            cs.levels,
            cs.stencils.patch_points.len(),
            if n_doubled > 0 { format!(" ({n_doubled} samples under non-quad faces: OpenSubdiv's are 2×)") } else { String::new() }
        );
        assert!(pos <= 1e-12 && der <= 1e-10, "{name}: {pos:e} {der:e}");
        worst = worst.max(pos);
    }
    eprintln!(
        "worst {worst:.1e}·diag over {} semi-sharp shapes",
        SEMI_SHARP.len()
    );
}

#[test]
fn an_isolation_level_refines_as_opensubdivs_refine_adaptive_does() {
    // --isolation 2 on cages that need no refinement: OpenSubdiv isolates their extraordinary vertices
    // adaptively to level 2 (RefineAdaptive(2)), gregvox refines the whole cage twice; the same surface.
    for name in ["catmark_cube", "catmark_gregory_test6", "catmark_tent"] {
        let mut cage = load_obj_cage(model(&format!("opensubdiv/{name}.obj"))).unwrap();
        cage.tags.isolation = Some(2);
        let e = LimitEvaluator::new(&cage, Tangents::OpenSubdiv).unwrap();
        let samples = read_ptex(&format!("{name}_iso2"));
        let ours = e
            .evaluate(&samples.iter().map(|s| s.at).collect::<Vec<_>>())
            .unwrap();
        let d = diag(&cage.mesh.positions);
        let pos = samples
            .iter()
            .zip(&ours)
            .map(|(s, o)| (o.position - s.p).length() / d)
            .fold(0.0, f64::max);
        eprintln!("{name:22} --isolation 2 vs RefineAdaptive(2): position {pos:.1e}·diag");
        assert!(pos <= 1e-12, "{name}: {pos:e}");
        // The isolation changed the surface (Gregory caps at level 2, not 0) where there are
        // extraordinary vertices.
        let plain = LimitEvaluator::new(
            &load_obj_cage(model(&format!("opensubdiv/{name}.obj"))).unwrap(),
            Tangents::OpenSubdiv,
        )
        .unwrap()
        .evaluate(&samples.iter().map(|s| s.at).collect::<Vec<_>>())
        .unwrap();
        let moved = plain
            .iter()
            .zip(&ours)
            .map(|(a, b)| (a.position - b.position).length() / d)
            .fold(0.0, f64::max);
        assert!(moved > 1e-6, "{name}: --isolation changed nothing");
    }
    // Below what the cage needs: refused, naming why.
    let mut cage = load_obj_cage(model("opensubdiv/catmark_cube_creases1.obj")).unwrap();
    cage.tags.isolation = Some(3);
    let err = LimitEvaluator::new(&cage, Tangents::OpenSubdiv)
        .err()
        .unwrap()
        .to_string();
    assert!(
        err.contains("--isolation 3") && err.contains("5 level"),
        "{err}"
    );
}

#[test]
fn gregvox_evaluate_refuses_a_cage_past_the_valence_limit_before_any_work() {
    // A 200-gon refined once makes a vertex of valence 200: W would grow with its square.
    let dir = std::env::temp_dir().join(format!("gregvox-evaluate-ngon-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut obj = String::new();
    for k in 0..200 {
        let a = k as f64 * std::f64::consts::TAU / 200.0;
        obj += &format!("v {} {} 0\n", a.cos(), a.sin());
    }
    obj += "f";
    for k in 1..=200 {
        obj += &format!(" {k}");
    }
    obj += "\n";
    let cage = dir.join("ngon.obj");
    std::fs::write(&cage, obj).unwrap();
    let fuv = dir.join("fuv.npy");
    write_npy_f64(&fuv, &[[0.0, 0.5, 0.5]]);
    let out = dir.join("p.npz");
    let r = std::process::Command::new(env!("CARGO_BIN_EXE_gregvox"))
        .arg("evaluate")
        .arg(&cage)
        .arg("--at")
        .arg(&fuv)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        !r.status.success() && err.contains("ngon.obj") && err.contains("valence"),
        "{err}"
    );
    assert!(!out.exists());
    std::fs::remove_dir_all(&dir).ok();
}
