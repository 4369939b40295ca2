//! Face-varying UVs against OpenSubdiv's face-varying patches (fixtures `*.fvar` from
//! tests/oracle/osd_gregory.cpp --fvar: smooth face-varying patches, RefineAdaptive(L), at random ptex
//! (face, u, v) and on the faces' edges), every `facevaryinginterpolateboundary` rule, seams, holes, creases.
#[path = "surface_common.rs"]
mod common;
use common::*;
use glam::DVec3;
use gregvox::mesh::load_obj_cage;
use gregvox::surface::fvar::uv_cage;
use gregvox::surface::{GregoryStencils, LimitEvaluator, Tangents};

/// One OpenSubdiv sample: (face, u, v), P, uv, and whether OpenSubdiv truncated a face point of its patch
/// (the oracle's flag: tests/oracle/osd_gregory.cpp --fvar).
struct Sample {
    at: (u32, f64, f64),
    p: DVec3,
    uv: [f64; 2],
    truncated: bool,
}

fn read_fvar(name: &str) -> Vec<Sample> {
    let path = format!(
        "{}/tests/fixtures/surface/{name}.fvar",
        env!("CARGO_MANIFEST_DIR")
    );
    let b = std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let n = u32::from_le_bytes(b[..4].try_into().unwrap()) as usize;
    let f: Vec<f64> = b[4..]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect();
    assert_eq!(f.len(), 9 * n, "{path}");
    f.chunks_exact(9)
        .map(|r| Sample {
            at: (r[0] as u32, r[1], r[2]),
            p: DVec3::new(r[3], r[4], r[5]),
            uv: [r[6], r[7]],
            truncated: r[8] != 0.0,
        })
        .collect()
}

/// (fixture, model): the OpenSubdiv shapes with UVs, and gregvox's own cages for the other rules.
const SHAPES: &[(&str, &str)] = &[
    ("catmark_cube", "opensubdiv/catmark_cube.obj"),
    ("catmark_torus", "opensubdiv/catmark_torus.obj"),
    ("catmark_fvar_bound0", "opensubdiv/catmark_fvar_bound0.obj"),
    ("catmark_fvar_bound1", "opensubdiv/catmark_fvar_bound1.obj"),
    ("catmark_fvar_bound2", "opensubdiv/catmark_fvar_bound2.obj"),
    ("catmark_fvar_bound3", "opensubdiv/catmark_fvar_bound3.obj"),
    ("catmark_fvar_bound4", "opensubdiv/catmark_fvar_bound4.obj"),
    (
        "catmark_fvar_project0",
        "opensubdiv/catmark_fvar_project0.obj",
    ),
    (
        "catmark_cubes_infsharp",
        "opensubdiv/catmark_cubes_infsharp.obj",
    ),
    (
        "catmark_cubes_semisharp",
        "opensubdiv/catmark_cubes_semisharp.obj",
    ),
    (
        "catmark_xord_interior",
        "opensubdiv/catmark_xord_interior.obj",
    ),
    (
        "catmark_xord_boundary",
        "opensubdiv/catmark_xord_boundary.obj",
    ),
    ("catmark_edgenone", "opensubdiv/catmark_edgenone.obj"),
    ("catmark_edgecorner", "opensubdiv/catmark_edgecorner.obj"),
    ("catmark_hole_test1", "opensubdiv/catmark_hole_test1.obj"),
    ("catmark_nonquads", "opensubdiv/catmark_nonquads.obj"),
    ("catmark_inf_crease0", "opensubdiv/catmark_inf_crease0.obj"),
    (
        "catmark_gregory_test6",
        "opensubdiv/catmark_gregory_test6.obj",
    ),
    ("catmark_chaikin0", "opensubdiv/catmark_chaikin0.obj"),
    ("catmark_quadstrips", "opensubdiv/catmark_quadstrips.obj"),
];

fn uv_diag(values: &[[f64; 2]]) -> f64 {
    let p: Vec<DVec3> = values.iter().map(|v| DVec3::new(v[0], v[1], 0.0)).collect();
    diag(&p)
}

/// The largest UV error (over the UV bounding-box diagonal) of fixture `name` on the cage at `path`, where
/// OpenSubdiv's patch is intact and where it truncated a face point (see [`Sample::truncated`]); the
/// positions are checked on the way.
fn uv_error(name: &str, path: &str) -> (f64, f64) {
    {
        let cage = load_obj_cage(path).unwrap();
        let cs = GregoryStencils::from_cage(&cage, Tangents::OpenSubdiv).unwrap();
        let e = LimitEvaluator::from_stencils(&cage, &cs).unwrap();
        let uvc = uv_cage(&cage, cs.levels)
            .unwrap()
            .expect("the shape has UVs");
        let eu = LimitEvaluator::new(&uvc, Tangents::OpenSubdiv).unwrap();
        let samples = read_fvar(name);
        let at: Vec<_> = samples.iter().map(|s| s.at).collect();
        let pos = e.evaluate_first_order(&at).unwrap();
        let uvs = eu.evaluate_first_order(&at).unwrap();
        let d = diag(&cage.mesh.positions);
        let du = uv_diag(&cage.uv.as_ref().unwrap().values);
        let (mut ep, mut eu_max, mut at_worst) = (0.0f64, 0.0f64, (0, 0.0, 0.0));
        let (mut truncated, mut n_truncated) = (0.0f64, 0);
        for ((s, p), q) in samples.iter().zip(&pos).zip(&uvs) {
            ep = ep.max((p.position - s.p).length() / d);
            let err = (q.position.truncate() - glam::DVec2::from(s.uv)).length() / du;
            if s.truncated {
                truncated = truncated.max(err);
                n_truncated += 1;
            } else if err > eu_max {
                eu_max = err;
                at_worst = s.at;
            }
            assert_eq!(q.position.z, 0.0);
        }
        eprintln!(
            "{name:28} rule {} levels {}: {} samples, position {ep:.1e}·diag, uv {eu_max:.1e}·uv diag (worst at \
             {at_worst:?}); {n_truncated} on OpenSubdiv's truncated patches, uv {truncated:.1e}",
            cage.tags.fvar_linear().tag(),
            cs.levels,
            samples.len()
        );
        assert!(ep <= 1e-12, "{name}: position {ep:e}");
        (eu_max, truncated)
    }
}

#[test]
fn uvs_match_opensubdivs_face_varying_patches() {
    let mut worst = 0.0f64;
    for &(name, rel) in SHAPES {
        let (e, truncated) = uv_error(name, &model(rel));
        assert!(e <= 1e-12, "{name}: uv {e:e}");
        assert_eq!(
            truncated, 0.0,
            "{name}: rule 1 sharpens no span of two faces"
        );
        worst = worst.max(e);
    }
    eprintln!("worst uv error {worst:.1e}·uv diag");
}

#[test]
fn every_face_varying_rule_matches_opensubdiv() {
    // Linear none (0), corners plus one (2), plus two (3), boundaries (4), all (5) on seams, UV corners,
    // darts, a bowtie-free project map, semi-sharp corners (bound2), triangles (bound3), infinitely sharp
    // creases crossing seams (inf_crease0) and edge-and-corner boundaries (edgecorner).
    let mut worst = 0.0f64;
    let mut bad = Vec::new();
    for base in [
        "catmark_cube",
        "catmark_fvar_bound0",
        "catmark_fvar_bound1",
        "catmark_fvar_bound2",
        "catmark_fvar_bound3",
        "catmark_fvar_project0",
        "catmark_xord_interior",
        "catmark_edgecorner",
        "catmark_inf_crease0",
    ] {
        for rule in [0, 2, 3, 4, 5] {
            let name = format!("{base}_r{rule}");
            let path = format!(
                "{}/tests/fixtures/surface/cages/fvar/{name}.obj",
                env!("CARGO_MANIFEST_DIR")
            );
            let (e, truncated) = uv_error(&name, &path);
            if e > 1e-12 {
                bad.push(format!("{name}: uv {e:.1e}"));
            }
            // Where OpenSubdiv dropped terms of a face point the patches differ inside, within a few
            // percent of the UV extent (measured: 3.7e-2 at most); a larger gap is a bug of ours.
            if truncated > 5e-2 {
                bad.push(format!("{name}: uv {truncated:.1e} on truncated patches"));
            }
            worst = worst.max(e);
        }
    }
    eprintln!("worst uv error {worst:.1e}·uv diag");
    assert!(bad.is_empty(), "{bad:#?}");
}
