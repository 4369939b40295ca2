//! Specification of `gregvox tessellate`'s Gregory options through the binary (validation layer forced on):
//! `--tangents exact` evaluates the exact-limit-tangent ACC-2 patches, and `--adaptive` writes each patch's
//! own grid in the documented order.
mod common;
use glam::DVec3;
use gregvox::mesh::load_obj;
use gregvox::surface::{tessellate, GregoryStencils, Tangents};
use std::process::{Command, Output};

fn gregvox(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gregvox"))
        .args(args)
        .env("GREGVOX_VALIDATION", "1")
        .output()
        .unwrap()
}

fn model(name: &str) -> String {
    format!("{}/assets/models/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("gregvox-gregory-cli-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// The `v` and `vn` lines of an OBJ.
fn read_obj(path: &std::path::Path) -> (Vec<DVec3>, Vec<DVec3>) {
    let text = std::fs::read_to_string(path).unwrap();
    let (mut v, mut vn) = (Vec::new(), Vec::new());
    for line in text.lines() {
        let mut it = line.split_whitespace();
        let tag = it.next();
        if tag != Some("v") && tag != Some("vn") {
            continue;
        }
        let xyz: Vec<f64> = it.map(|s| s.parse().unwrap()).collect();
        let p = DVec3::new(xyz[0], xyz[1], xyz[2]);
        if tag == Some("v") {
            v.push(p);
        } else {
            vn.push(p);
        }
    }
    (v, vn)
}

fn diag(p: &[DVec3]) -> f64 {
    let lo = p.iter().fold(DVec3::splat(f64::MAX), |a, b| a.min(*b));
    let hi = p.iter().fold(DVec3::splat(f64::MIN), |a, b| a.max(*b));
    (hi - lo).length()
}

#[test]
fn tangents_exact_evaluates_the_exact_limit_tangent_patches() {
    // catmark_cube: every corner has valence 3, where the two masks differ most (|Ep − P| .2286 vs .2879 on
    // a symmetric unit ring, docs/notes/gregory.md §3.5).
    let cube = model("opensubdiv/catmark_cube.obj");
    let level = 6;
    let mesh = load_obj(&cube).unwrap();
    let d = diag(&mesh.positions);
    let reference = |t: Tangents| {
        let cs = GregoryStencils::from_mesh(&mesh, t).unwrap();
        tessellate(&cs.stencils.patches_f64(&mesh.positions).unwrap(), level)
    };
    let (exact, osd) = (reference(Tangents::Exact), reference(Tangents::OpenSubdiv));
    let mut worst = [0.0f64; 2];
    for (mode, out) in [("exact", "exact.obj"), ("opensubdiv", "osd.obj")] {
        let path = tmp(out);
        let o = gregvox(&[
            "tessellate",
            &cube,
            "--level",
            &level.to_string(),
            "--tangents",
            mode,
            "--no-weld",
            "--out",
            path.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (v, vn) = read_obj(&path);
        assert_eq!(v.len(), exact.positions.len());
        assert_eq!(vn.len(), v.len());
        for (k, r) in [&exact, &osd].into_iter().enumerate() {
            let gap = v
                .iter()
                .zip(&r.positions)
                .map(|(a, b)| (*a - *b).length() / d)
                .fold(0.0, f64::max);
            if (mode == "exact") == (k == 0) {
                // The OBJ is the f32 GPU surface printed with limited digits: the 1e-5 × diag.
                assert!(
                    gap <= 1e-5,
                    "--tangents {mode} vs its f64 reference: {gap:e} × diag"
                );
            } else {
                worst[k] = gap;
            }
        }
    }
    eprintln!(
        "catmark_cube L={level}: exact-mode OBJ vs OpenSubdiv-mode reference {:.2e} × diag, and vice versa {:.2e}",
        worst[1], worst[0]
    );
    // Negative control: the two modes really are different surfaces (far beyond the 1e-5 tolerance).
    assert!(worst[0] > 1e-3 && worst[1] > 1e-3, "{worst:?}");
}

#[test]
fn tangents_on_a_beziex_model_is_one_clear_error() {
    let dir = tmp("tangents-beziex");
    std::fs::create_dir_all(&dir).unwrap();
    let o = gregvox(&[
        "tessellate",
        &model("beziex/19_Sphere1.gzjson"),
        "--tangents",
        "exact",
        "--out",
        dir.join("sphere.obj").to_str().unwrap(),
    ]);
    common::assert_one_error_line("--tangents on Beziex", &o, &["--tangents", "19_Sphere1"]);
    assert_eq!(
        common::entries_under(&dir),
        Vec::<String>::new(),
        "nothing written, nothing left behind"
    );
}

#[test]
fn adaptive_writes_each_patch_grid_at_its_level_without_cracks() {
    let cube = model("opensubdiv/catmark_cube.obj");
    let mesh = load_obj(&cube).unwrap();
    let d = diag(&mesh.positions);
    let path = tmp("adaptive.obj");
    // The eye close to one corner of the cube: near faces fine, far faces coarse.
    let o = gregvox(&[
        "tessellate",
        &cube,
        "--level",
        "16",
        "--adaptive",
        "40",
        "--eye",
        "1.2,1.0,1.6",
        "--viewport",
        "800x600",
        "--no-weld",
        "--out",
        path.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&path).unwrap();
    let levels: Vec<u32> = text
        .lines()
        .find_map(|l| l.strip_prefix("# levels "))
        .expect("a '# levels' comment")
        .split_whitespace()
        .map(|s| s.parse().unwrap())
        .collect();
    assert_eq!(levels.len(), 6);
    let distinct: std::collections::BTreeSet<u32> = levels.iter().copied().collect();
    eprintln!("catmark_cube --adaptive 40: levels {levels:?}");
    assert!(distinct.len() >= 2, "levels should vary: {levels:?}");
    let (v, vn) = read_obj(&path);
    let sizes: Vec<usize> = levels
        .iter()
        .map(|&l| ((l + 1) * (l + 1)) as usize)
        .collect();
    assert_eq!(v.len(), sizes.iter().sum::<usize>());
    assert_eq!(vn.len(), v.len());
    let faces = text.lines().filter(|l| l.starts_with("f ")).count() as u32;
    assert_eq!(faces, levels.iter().map(|l| 2 * l * l).sum::<u32>());
    // Interior vertices: the f64 surface at the patch's own level (the f32 tolerance 1e-5 × diag).
    let cs = GregoryStencils::from_mesh(&mesh, Tangents::OpenSubdiv).unwrap();
    let patches = cs.stencils.patches_f64(&mesh.positions).unwrap();
    let mut start = 0;
    let mut boundary: Vec<Vec<[u64; 3]>> = Vec::new();
    for (p, &l) in levels.iter().enumerate() {
        let n = (l + 1) as usize;
        let grid = &v[start..start + n * n];
        let r = tessellate(&patches[p..p + 1], l);
        let mut edge = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let q = grid[j * n + i];
                if i == 0 || j == 0 || i == n - 1 || j == n - 1 {
                    edge.push([q.x, q.y, q.z].map(f64::to_bits));
                } else {
                    let gap = (q - r.positions[j * n + i]).length() / d;
                    assert!(gap <= 1e-5, "patch {p} ({i},{j}): {gap:e} × diag");
                }
            }
        }
        boundary.push(edge);
        start += n * n;
    }
    // Crack-free through the file: every boundary vertex has a bit-identical twin in another patch (the cube is
    // closed, and snapped rows only use samples of the shared, coarser edge level).
    for (p, edge) in boundary.iter().enumerate() {
        for b in edge {
            assert!(
                boundary
                    .iter()
                    .enumerate()
                    .any(|(q, other)| q != p && other.contains(b)),
                "patch {p}: a boundary vertex without a twin (a crack)"
            );
        }
    }
}
