//! Specification of gregvox under bad input, unwritable outputs and tight memory (issue 9). Every case runs the
//! real binary with the validation layer forced on (`GREGVOX_VALIDATION=1`) and states what the user sees:
//!
//! - a failure exits with code 1 and prints exactly ONE `gregvox: error:` line, which names the input (path
//!   or flag) and the problem; stderr has no "panicked" and no validation message; no output file is left
//!   (a pre-existing output is untouched);
//! - input that is unusual but valid (valence-2 and degenerate quads, a million-vertex polygon for the
//!   commands that can take it) succeeds with a sane, finite result;
//! - every command ends with no live GPU allocation and no live Vulkan object (the CLI itself fails on either,
//!   see `cli::main`), checked here by the absence of the messages it and the layer print.
//!
//! /dev/full cases first check that /dev/full is a character device and check again afterwards: a writer
//! that renamed a temporary file onto it (as root, in CI) would replace the device node.
use std::ffi::OsStr;
use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

// ---------------------------------------------------------------------------------------------------------
// Helpers

fn gregvox_env<S: AsRef<OsStr>>(args: &[S], env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_gregvox"));
    c.args(args).env("GREGVOX_VALIDATION", "1");
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("run gregvox")
}

fn gregvox<S: AsRef<OsStr>>(args: &[S]) -> Output {
    gregvox_env(args, &[])
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// No panic, no validation message, no leak report in `err`.
fn assert_hygienic(what: &str, err: &str) {
    assert!(!err.contains("panicked"), "{what}: panic:\n{err}");
    assert!(
        !err.to_lowercase().contains("validation"),
        "{what}: validation message:\n{err}"
    );
    assert!(
        !err.contains("still alive"),
        "{what}: GPU allocation leaked:\n{err}"
    );
}

/// The failure contract: exit code 1, one error line naming `names` and saying `problem`.
fn assert_clear_failure(what: &str, out: &Output, names: &str, problem: &str) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(1), "{what}: exit code\n{err}");
    assert_hygienic(what, &err);
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("gregvox: error:"))
        .collect();
    assert_eq!(lines.len(), 1, "{what}: one error line expected:\n{err}");
    assert!(
        lines[0].contains(names) && lines[0].contains(problem),
        "{what}: the error line should name '{names}' and say '{problem}':\n{err}"
    );
}

fn assert_success(what: &str, out: &Output) {
    let err = stderr(out);
    assert!(out.status.success(), "{what}: failed\n{err}");
    assert_hygienic(what, &err);
}

/// A fresh scratch folder, removed at the end.
struct Scratch(PathBuf);

impl Scratch {
    fn new(name: &str) -> Scratch {
        let dir =
            std::env::temp_dir().join(format!("gregvox-hardening-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }
    fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
    fn write(&self, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
        let p = self.path(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }
    /// Every regular file under the folder (relative names, sorted).
    fn files(&self) -> Vec<String> {
        fn walk(dir: &Path, base: &Path, out: &mut Vec<String>) {
            for e in std::fs::read_dir(dir).unwrap().flatten() {
                let p = e.path();
                let t = std::fs::symlink_metadata(&p).unwrap().file_type();
                if t.is_dir() {
                    // An empty folder left behind counts too (e.g. a demo --out for a refused model).
                    if std::fs::read_dir(&p).unwrap().next().is_none() {
                        out.push(format!("{}/", p.strip_prefix(base).unwrap().display()));
                    }
                    walk(&p, base, out);
                } else {
                    out.push(p.strip_prefix(base).unwrap().display().to_string());
                }
            }
        }
        let mut v = Vec::new();
        walk(&self.0, &self.0, &mut v);
        v.sort();
        v
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

fn model(rel: &str) -> String {
    format!("{}/assets/models/{rel}", env!("CARGO_MANIFEST_DIR"))
}

/// Every command that reads an OBJ input, with its outputs inside `dir`.
fn reading_commands(input: &str, dir: &Scratch) -> Vec<(&'static str, Vec<String>)> {
    vec![
        ("mesh", vec!["mesh".into(), input.into()]),
        (
            "subdivide",
            vec![
                "subdivide".into(),
                input.into(),
                "--out".into(),
                s(&dir.path("sub.obj")),
            ],
        ),
        (
            "tessellate",
            vec![
                "tessellate".into(),
                input.into(),
                "--level".into(),
                "2".into(),
                "--out".into(),
                s(&dir.path("tess.obj")),
            ],
        ),
        (
            "voxelize",
            vec![
                "voxelize".into(),
                input.into(),
                "--res".into(),
                "8".into(),
                "--out".into(),
                s(&dir.path("vox.binvox")),
            ],
        ),
        (
            "voxelize --gregory-level",
            vec![
                "voxelize".into(),
                input.into(),
                "--res".into(),
                "8".into(),
                "--gregory-level".into(),
                "2".into(),
                "--out".into(),
                s(&dir.path("greg.binvox")),
            ],
        ),
        (
            "demo --model",
            vec![
                "demo".into(),
                "--offscreen".into(),
                "--scene".into(),
                "cage".into(),
                "--model".into(),
                input.into(),
                "--frames".into(),
                "1".into(),
                "--size".into(),
                "64x48".into(),
                "--out".into(),
                s(&dir.path("demo")),
            ],
        ),
    ]
}

/// Runs every reading command on `input`; each must fail clearly, naming the file and `problem`, and leave
/// no file but the inputs.
fn all_commands_refuse(case: &str, dir: &Scratch, input: &str, problem: &str) {
    let before = dir.files();
    for (name, args) in reading_commands(input, dir) {
        let out = gregvox(&args);
        assert_clear_failure(&format!("{case} / {name}"), &out, input, problem);
        assert_eq!(dir.files(), before, "{case} / {name}: output left behind");
    }
}

const TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

// ---------------------------------------------------------------------------------------------------------
// Unreadable and malformed input files, through every command that reads one

#[test]
fn a_missing_file_is_named() {
    let dir = Scratch::new("missing");
    let input = s(&dir.path("no-such-cage.obj"));
    all_commands_refuse("missing file", &dir, &input, "No such file or directory");
}

#[test]
fn a_directory_is_not_a_mesh() {
    let dir = Scratch::new("directory");
    let sub = dir.path("a-folder.obj");
    std::fs::create_dir(&sub).unwrap();
    all_commands_refuse("directory", &dir, &s(&sub), "Is a directory");
}

#[test]
fn an_empty_file_is_an_empty_mesh() {
    let dir = Scratch::new("empty");
    let input = s(&dir.write("empty.obj", ""));
    all_commands_refuse("empty file", &dir, &input, "empty mesh");
}

#[test]
fn binary_garbage_is_not_an_obj_text_file() {
    let dir = Scratch::new("garbage");
    // Deterministic noise (an LCG) with a NUL in it, and a second file that is invalid UTF-8 but NUL-free:
    // both byte-level refusals are covered.
    let mut x = 0x2545_f491_u32;
    let noise: Vec<u8> = (0..4096)
        .map(|_| {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (x >> 24) as u8
        })
        .collect();
    assert!(noise.contains(&0));
    let with_nul = s(&dir.write("noise.obj", &noise));
    all_commands_refuse("binary with NUL", &dir, &with_nul, "not an OBJ text file");
    let latin1: Vec<u8> = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 # caf\xe9\n".to_vec();
    let bad_utf8 = s(&dir.write("latin1.obj", latin1));
    all_commands_refuse("invalid UTF-8", &dir, &bad_utf8, "invalid UTF-8");
}

#[test]
fn non_finite_coordinates_are_refused_with_their_line() {
    let dir = Scratch::new("nonfinite");
    let nan = s(&dir.write("nan.obj", "v 0 0 0\nv 1 NaN 0\nv 0 1 0\nf 1 2 3\n"));
    all_commands_refuse(
        "NaN",
        &dir,
        &nan,
        "line 2: vertex 2 has a non-finite coordinate (NaN)",
    );
    let inf = s(&dir.write("inf.obj", "v 0 0 0\nv 1 0 0\nv 0 -inf 0\nf 1 2 3\n"));
    all_commands_refuse(
        "-inf",
        &dir,
        &inf,
        "line 3: vertex 3 has a non-finite coordinate (-inf)",
    );
}

#[test]
fn bad_face_indices_are_refused_with_their_line() {
    let dir = Scratch::new("indices");
    let oor = s(&dir.write("oor.obj", format!("{TRIANGLE}f 1 2 4\n")));
    all_commands_refuse(
        "index past the end",
        &dir,
        &oor,
        "line 4: face 1: vertex index 4 is out of range (there are 3 vertices)",
    );
    let zero = s(&dir.write("zero.obj", format!("{TRIANGLE}f 0 1 2\n")));
    all_commands_refuse("index 0", &dir, &zero, "face index 0 is invalid");
    let rel = s(&dir.write("rel.obj", format!("{TRIANGLE}f -1 -2 -4\n")));
    all_commands_refuse(
        "relative before the first",
        &dir,
        &rel,
        "points before the first vertex",
    );
    let two = s(&dir.write("two.obj", format!("{TRIANGLE}f 1 2\n")));
    all_commands_refuse(
        "2-vertex face",
        &dir,
        &two,
        "face has 2 vertices (a face needs at least 3)",
    );
    let one = s(&dir.write("one.obj", format!("{TRIANGLE}f 3\n")));
    all_commands_refuse("1-vertex face", &dir, &one, "face has 1 vertices");
    let rep = s(&dir.write("repeat.obj", format!("{TRIANGLE}f 1 2 1\n")));
    all_commands_refuse("repeated vertex", &dir, &rep, "appears twice in one face");
}

#[test]
fn a_million_vertex_face_is_handled_by_each_command() {
    // A convex planar million-gon: valid OBJ. Before hardening, loading checked repeated vertices with a
    // quadratic scan (and the mesh matrix looked up twins by scanning rows): hours. Now mesh, voxelize and
    // subdivide answer in seconds and the Gregory commands refuse the valence clearly.
    const N: usize = 1_000_000;
    let dir = Scratch::new("million");
    let mut text = String::with_capacity(N * 48);
    use std::fmt::Write;
    for i in 0..N {
        let a = std::f64::consts::TAU * i as f64 / N as f64;
        writeln!(text, "v {} {} 0", a.cos(), a.sin()).unwrap();
    }
    text.push('f');
    for i in 1..=N {
        write!(text, " {i}").unwrap();
    }
    text.push('\n');
    let input = s(&dir.write("million.obj", text));

    let out = gregvox(&["mesh", &input, "--json"]);
    assert_success("million / mesh", &out);
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        (r["faces"].as_u64(), r["edges"].as_u64()),
        (Some(1), Some(N as u64))
    );
    assert_eq!(r["euler_characteristic"], 1, "a disc");

    // Flat: no volume, so no solid voxel, on the CPU path (the GPU peel path is covered by voxel_cli).
    let vox = dir.path("million.binvox");
    let out = gregvox(&[
        "voxelize",
        &input,
        "--res",
        "8",
        "--method",
        "cpu",
        "--out",
        &s(&vox),
    ]);
    assert_success("million / voxelize", &out);
    let grid = gregvox::voxel::export::parse_binvox(&std::fs::read(&vox).unwrap()).unwrap();
    assert_eq!(grid.count(), 0);

    let sub = dir.path("million-sub.obj");
    let out = gregvox(&["subdivide", &input, "--out", &s(&sub)]);
    assert_success("million / subdivide", &out);
    let m = gregvox::mesh::load_obj(&sub).unwrap();
    assert_eq!(
        (m.n_faces(), m.positions.len()),
        (N, 2 * N + 1),
        "N quads around one centre"
    );

    let err = "face 1 has 1000000 vertices";
    for (name, args) in reading_commands(&input, &dir) {
        if name.starts_with("tessellate") || name.contains("gregory") || name.starts_with("demo") {
            let out = gregvox(&args);
            assert_clear_failure(&format!("million / {name}"), &out, &input, err);
            assert!(stderr(&out).contains("valence up to 64"));
        }
    }
    assert_eq!(
        dir.files(),
        ["million-sub.obj", "million.binvox", "million.obj"]
    );
}

// ---------------------------------------------------------------------------------------------------------
// Cages: invalid for Gregory patches, or valid but unusual

#[test]
fn a_non_manifold_cage_is_refused_by_the_gregory_commands() {
    let dir = Scratch::new("nonmanifold");
    // Three quads on one edge (a "book" with three pages).
    let input = s(&dir.write(
        "book.obj",
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 1 0 1\nv 0 0 1\nv 1 0 -1\nv 0 0 -1\n\
         f 1 2 3 4\nf 2 1 6 5\nf 1 2 7 8\n",
    ));
    for (name, args) in reading_commands(&input, &dir) {
        if name == "tessellate" || name.contains("gregory") || name.starts_with("demo") {
            let out = gregvox(&args);
            assert_clear_failure(&format!("book / {name}"), &out, &input, "not a manifold");
        }
    }
    // The topology report itself is fine with it and says so.
    let out = gregvox(&["mesh", &input, "--json"]);
    assert_success("book / mesh", &out);
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(r["non_manifold_edges"], 1);
    assert!(dir.files() == ["book.obj"]);
}

/// Reads a tessellation OBJ: (positions, normals).
fn read_tessellation(path: &Path) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let text = std::fs::read_to_string(path).unwrap();
    let (mut v, mut n) = (Vec::new(), Vec::new());
    for l in text.lines() {
        let mut t = l.split_whitespace();
        let key = t.next();
        let xyz = || -> [f64; 3] {
            let c: Vec<f64> = l
                .split_whitespace()
                .skip(1)
                .map(|x| x.parse().unwrap())
                .collect();
            [c[0], c[1], c[2]]
        };
        match key {
            Some("v") => v.push(xyz()),
            Some("vn") => n.push(xyz()),
            _ => {}
        }
    }
    (v, n)
}

#[test]
fn valence_two_and_degenerate_quads_are_valid_input_with_finite_output() {
    // Documented behaviour: these are valid cages. A lone quad (four valence-2 boundary corners), a closed
    // two-quad "pillow" (every vertex valence 2) and a collinear quad (zero area) all tessellate; the output
    // has (L+1)² vertices per patch, finite positions inside the cage's box, and unit normals where they are
    // defined (the collinear quad has no tangent plane: its normals are still finite, never NaN).
    let dir = Scratch::new("valence2");
    let cases = [
        (
            "lone quad",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n",
            1,
            true,
        ),
        (
            "pillow",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf 4 3 2 1\n",
            2,
            true,
        ),
        (
            "collinear quad",
            "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nf 1 2 3 4\n",
            1,
            false,
        ),
    ];
    const L: usize = 4;
    for (name, obj, patches, unit_normals) in cases {
        let input = s(&dir.write(&format!("{name}.obj"), obj));
        let out_path = dir.path(&format!("{name}-tess.obj"));
        let out = gregvox(&[
            "tessellate",
            &input,
            "--level",
            "4",
            "--no-weld",
            "--out",
            &s(&out_path),
        ]);
        assert_success(name, &out);
        let (v, n) = read_tessellation(&out_path);
        assert_eq!(v.len(), patches * (L + 1) * (L + 1), "{name}");
        assert_eq!(n.len(), v.len(), "{name}");
        for p in &v {
            assert!(
                p.iter()
                    .all(|c| c.is_finite() && (-1e-6..=3.0 + 1e-6).contains(c)),
                "{name}: {p:?}"
            );
        }
        for q in &n {
            assert!(q.iter().all(|c| c.is_finite()), "{name}: normal {q:?}");
            if unit_normals {
                let len = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
                // f32 normalisation written with shortest round-trip text: 1e-5.
                assert!((len - 1.0).abs() < 1e-5, "{name}: |n| = {len}");
            }
        }
    }
    // The collinear quad has no area: voxelize says so instead of producing an empty grid silently.
    let input = s(&dir.path("collinear quad.obj"));
    let out = gregvox(&["voxelize", &input, "--res", "8"]);
    assert_clear_failure(
        "collinear / voxelize",
        &out,
        &input,
        "no triangle with a non-zero area",
    );
}

#[test]
fn zero_area_triangles_are_removed_with_a_note_or_refused_when_nothing_is_left() {
    let dir = Scratch::new("zeroarea");
    // A tetrahedron plus a degenerate sliver on one of its edges.
    let tet = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 0.5 0 0\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\nf 1 5 2\n";
    let input = s(&dir.write("tet.obj", tet));
    for method in ["cpu", "peel"] {
        let out = gregvox(&[
            "voxelize", &input, "--res", "16", "--method", method, "--json",
        ]);
        assert_success(method, &out);
        let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(r["removed"]["zero_area"], 1, "{method}");
        assert_eq!(r["triangles"], 4, "{method}");
        // Tetrahedron volume 1/6 of the unit cube: 16³/6 ≈ 683 voxel centres, ± the surface layer.
        let solid = r["solid_voxels"].as_u64().unwrap();
        assert!((500..=800).contains(&solid), "{method}: {solid}");
        assert!(stderr(&out).contains("zero-area"), "{method}: the note");
    }
    let flat = s(&dir.write(
        "flat.obj",
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nf 1 2 3\nf 2 3 4\n",
    ));
    for method in ["cpu", "peel", "abuffer"] {
        let out = gregvox(&["voxelize", &flat, "--res", "8", "--method", method]);
        assert_clear_failure(method, &out, &flat, "no triangle with a non-zero area");
    }
}

// ---------------------------------------------------------------------------------------------------------
// Flags past the limits

#[test]
fn resolutions_and_levels_past_the_limits_are_named() {
    let dir = Scratch::new("limits");
    let cube = model("opensubdiv/catmark_cube.obj");
    let out_path = s(&dir.path("x.binvox"));
    for res in ["0", "2049", "100000"] {
        let out = gregvox(&["voxelize", &cube, "--res", res, "--out", &out_path]);
        assert_clear_failure(
            &format!("--res {res}"),
            &out,
            &format!("--res {res}"),
            "must be between 1 and 2048",
        );
    }
    let out = gregvox(&["voxelize", &cube, "--res", "8", "--gregory-level", "65"]);
    assert_clear_failure("--gregory-level 65", &out, "level", "64");
    let tess = s(&dir.path("t.obj"));
    for level in ["0", "65"] {
        let out = gregvox(&["tessellate", &cube, "--level", level, "--out", &tess]);
        assert_clear_failure(
            &format!("--level {level}"),
            &out,
            &format!("--level {level}"),
            "must be between 1 and 64",
        );
        let out = gregvox(&[
            "demo",
            "--offscreen",
            "--scene",
            "cage",
            "--model",
            &cube,
            "--level",
            level,
            "--frames",
            "1",
            "--out",
            &s(&dir.path("demo")),
        ]);
        assert_eq!(
            out.status.code(),
            Some(1),
            "demo --level {level}: {}",
            stderr(&out)
        );
        assert_hygienic("demo --level", &stderr(&out));
        assert!(stderr(&out).contains("level"), "{}", stderr(&out));
    }
    // A malformed number is clap's business: exit code 2, naming the flag.
    let out = gregvox(&["voxelize", &cube, "--res", "lots"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("--res"));
    assert!(dir
        .files()
        .iter()
        .all(|f| !f.ends_with(".binvox") && !f.ends_with(".obj")));
}

#[test]
fn malformed_gzjson_models_are_named() {
    use flate2::{write::GzEncoder, Compression};
    use std::io::Write;
    let dir = Scratch::new("gzjson");
    let gz = |text: &str| {
        let mut e = GzEncoder::new(Vec::new(), Compression::fast());
        e.write_all(text.as_bytes()).unwrap();
        e.finish().unwrap()
    };
    let cases: [(&str, Vec<u8>, &str); 4] = [
        (
            "not-gzip.gzjson",
            b"this is not gzip".to_vec(),
            "not a Beziex model",
        ),
        ("not-json.gzjson", gz("hello, world"), "not a Beziex model"),
        ("missing-fields.gzjson", gz("{\"foo\": 1}"), "missing field"),
        (
            "truncated.gzjson",
            gz("{\"foo\": 1}")[..12].to_vec(),
            "not a gzip stream",
        ),
    ];
    for (name, bytes, problem) in cases {
        let input = s(&dir.write(name, bytes));
        let out = gregvox(&["tessellate", &input, "--out", &s(&dir.path("t.obj"))]);
        assert_clear_failure(name, &out, &input, problem);
    }
    assert!(!dir.path("t.obj").exists());
}

// ---------------------------------------------------------------------------------------------------------
// Outputs that cannot be written

/// Every writer of every command, writing to `target` (a path built by `f` from a file name).
fn writers(cube: &str, f: &dyn Fn(&str) -> String) -> Vec<(&'static str, Vec<String>)> {
    let v = |a: &[&str]| a.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    vec![
        (
            "subdivide --out",
            v(&["subdivide", cube, "--out", &f("sub.obj")]),
        ),
        (
            "tessellate --out",
            v(&["tessellate", cube, "--level", "2", "--out", &f("tess.obj")]),
        ),
        (
            "voxelize --out",
            v(&["voxelize", cube, "--res", "8", "--out", &f("vox.binvox")]),
        ),
        (
            "voxelize --out .raw",
            v(&["voxelize", cube, "--res", "8", "--out", &f("vox.raw")]),
        ),
        (
            "voxelize --profile-json",
            v(&[
                "voxelize",
                cube,
                "--res",
                "8",
                "--profile-json",
                &f("profile.json"),
            ]),
        ),
        (
            "tessellate --trace",
            v(&[
                "tessellate",
                cube,
                "--level",
                "2",
                "--trace",
                &f("trace.json"),
            ]),
        ),
        (
            "demo --out",
            v(&[
                "demo",
                "--offscreen",
                "--scene",
                "cage",
                "--frames",
                "1",
                "--size",
                "64x48",
                "--out",
                &f("demo"),
            ]),
        ),
    ]
}

#[test]
fn unwritable_output_paths_are_named() {
    let dir = Scratch::new("unwritable");
    let cube = model("opensubdiv/catmark_cube.obj");
    // A folder that does not exist.
    let missing = dir.path("no-such-folder");
    for (name, args) in writers(&cube, &|f| s(&missing.join(f))) {
        let out = gregvox(&args);
        if name == "demo --out" {
            // The demo creates its output folder (and its parents): that is its documented behaviour.
            assert_success(name, &out);
            continue;
        }
        assert_clear_failure(name, &out, &s(&missing), "No such file or directory");
    }
    let _ = std::fs::remove_dir_all(&missing);
    // A path whose parent is a regular file: refused even as root.
    let file = dir.write("a-file", "x");
    for (name, args) in writers(&cube, &|f| s(&file.join(f))) {
        let out = gregvox(&args);
        let problem = if name == "demo --out" {
            "cannot create the output folder"
        } else {
            "Not a directory"
        };
        assert_clear_failure(name, &out, &s(&file), problem);
    }
    assert_eq!(dir.files(), ["a-file"]);
}

/// Runs gregvox as the unprivileged user nobody (uid and gid 65534) when the tests run as root, as CI does:
/// root ignores a folder's mode, so the refusal of a read-only folder can only be seen without it. The
/// binary is hard-linked (or copied) into `dir`, a root-owned 0755 folder nobody can enter, because the
/// checkout may sit under a folder only root can (`/root`). Mesa's shader cache is off: nobody has no home.
fn gregvox_as_nobody(dir: &Scratch, args: &[String]) -> Output {
    use std::os::unix::process::CommandExt;
    let bin = dir.path("gregvox-bin");
    if !bin.exists() && std::fs::hard_link(env!("CARGO_BIN_EXE_gregvox"), &bin).is_err() {
        std::fs::copy(env!("CARGO_BIN_EXE_gregvox"), &bin).unwrap();
    }
    Command::new(&bin)
        .args(args)
        .env("GREGVOX_VALIDATION", "1")
        .env("MESA_SHADER_CACHE_DISABLE", "true")
        .env("HOME", s(&dir.0))
        .uid(65534)
        .gid(65534)
        .output()
        .expect("run gregvox as nobody")
}

#[test]
fn a_read_only_folder_refuses_outputs_for_a_user_without_permission() {
    use std::os::unix::fs::PermissionsExt;
    let dir = Scratch::new("readonly");
    // The input inside the scratch folder, so that nobody can read it too.
    let cube = dir.write(
        "cube.obj",
        std::fs::read(model("opensubdiv/catmark_cube.obj")).unwrap(),
    );
    let cube = s(&cube);
    let ro = dir.path("ro");
    std::fs::create_dir(&ro).unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
    let as_root = std::fs::write(ro.join("probe"), "x").is_ok();
    let _ = std::fs::remove_file(ro.join("probe"));
    for (name, args) in writers(&cube, &|f| s(&ro.join(f))) {
        if as_root {
            let out = gregvox_as_nobody(&dir, &args);
            assert_clear_failure(
                &format!("{name} (as nobody)"),
                &out,
                &s(&ro),
                "Permission denied",
            );
            // Root writes into the 0555 folder (the mode does not bind it): completely, and cleanly.
            assert_success(name, &gregvox(&args));
        } else {
            assert_clear_failure(name, &gregvox(&args), &s(&ro), "Permission denied");
        }
    }
    let left: Vec<String> = dir
        .files()
        .into_iter()
        .filter(|f| f.contains(".tmp"))
        .collect();
    assert!(left.is_empty(), "temporary files left: {left:?}");
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o755)).unwrap();
}

fn assert_dev_full_is_a_device() {
    let m = std::fs::symlink_metadata("/dev/full").expect("/dev/full exists");
    assert!(
        m.file_type().is_char_device(),
        "/dev/full is not a character device any more: a writer replaced it (restore it with \
         `mknod -m 666 /dev/full c 1 7`)"
    );
}

#[test]
fn a_full_disk_is_reported_and_dev_full_survives() {
    assert_dev_full_is_a_device();
    let dir = Scratch::new("full");
    let cube = model("opensubdiv/catmark_cube.obj");
    // Voxel formats are chosen by extension, so voxelize and the demo's frames reach /dev/full through a
    // symlink (the writer follows it: a device is written in place, never renamed onto).
    std::fs::create_dir(dir.path("demo")).unwrap();
    for (link, target) in [
        ("vox.binvox", "/dev/full"),
        ("vox.raw", "/dev/full"),
        ("demo/frame_00000.png", "/dev/full"),
    ] {
        std::os::unix::fs::symlink(target, dir.path(link)).unwrap();
    }
    for (name, args) in writers(&cube, &|f| match f {
        "vox.binvox" | "vox.raw" | "demo" => s(&dir.path(f)),
        _ => "/dev/full".into(),
    }) {
        let out = gregvox(&args);
        let names = if args.iter().any(|a| a == "/dev/full") {
            "/dev/full".to_string()
        } else {
            s(&dir.0)
        };
        assert_clear_failure(name, &out, &names, "No space left on device");
        assert_dev_full_is_a_device();
    }
    // Nothing but the links (and the demo folder) remains: no temporary file.
    assert_eq!(
        dir.files(),
        ["demo/frame_00000.png", "vox.binvox", "vox.raw"]
    );
}

#[test]
fn a_failed_write_leaves_the_previous_output_intact() {
    let dir = Scratch::new("intact");
    let cube = model("opensubdiv/catmark_cube.obj");
    let old = b"previous result";
    // The run fails after voxelizing, on the profile (/dev/full), before the grid is written.
    let vox = dir.write("vox.binvox", old);
    let out = gregvox(&[
        "voxelize",
        &cube,
        "--res",
        "8",
        "--out",
        &s(&vox),
        "--profile-json",
        "/dev/full",
    ]);
    assert_clear_failure(
        "profile to /dev/full",
        &out,
        "/dev/full",
        "No space left on device",
    );
    assert_eq!(std::fs::read(&vox).unwrap(), old);
    // Bad input: the old output is untouched.
    let bad = s(&dir.write("nan.obj", "v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"));
    let sub = dir.write("sub.obj", old);
    let out = gregvox(&["subdivide", &bad, "--out", &s(&sub)]);
    assert_clear_failure("nan / subdivide", &out, &bad, "non-finite");
    assert_eq!(std::fs::read(&sub).unwrap(), old);
    // The writer itself, with an error injected half-way through: old contents kept, no temporary file.
    let target = dir.write("direct.obj", old);
    let err = gregvox::io::write_atomic(&target, |w| {
        w.write_all(b"half of a new")?;
        Err(std::io::Error::other("injected failure"))
    })
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("direct.obj") && err.contains("injected failure"),
        "{err}"
    );
    assert_eq!(std::fs::read(&target).unwrap(), old);
    assert_eq!(
        dir.files(),
        ["direct.obj", "nan.obj", "sub.obj", "vox.binvox"]
    );
    // And a successful write replaces the old contents completely.
    gregvox::io::write_atomic(&target, |w| w.write_all(b"new")).unwrap();
    assert_eq!(std::fs::read(&target).unwrap(), b"new");
}

// ---------------------------------------------------------------------------------------------------------
// Resource hygiene

#[test]
fn every_command_ends_with_no_live_gpu_object() {
    // The CLI fails (exit 1, "internal error") if any context of the run was destroyed with live allocations
    // or received a validation message, which includes the layer's report of undestroyed Vulkan objects at
    // device destruction; so success here means a clean ending.
    let dir = Scratch::new("hygiene");
    let cube = model("opensubdiv/catmark_cube.obj");
    let sphere = model("beziex/19_Sphere1.gzjson");
    let suzanne = model("suzanne.obj");
    let o = |f: &str| s(&dir.path(f));
    let runs: Vec<Vec<String>> = [
        vec!["info"],
        vec!["mesh", &suzanne],
        vec!["subdivide", &cube, "--levels", "2", "--out", &o("sub.obj")],
        vec![
            "tessellate",
            &cube,
            "--level",
            "4",
            "--out",
            &o("t.obj"),
            "--profile-json",
            &o("p.json"),
        ],
        vec![
            "tessellate",
            &cube,
            "--level",
            "4",
            "--path",
            "vertex",
            "--deform",
            "twist",
        ],
        vec!["tessellate", &sphere, "--level", "4", "--stats"],
        vec![
            "voxelize",
            &suzanne,
            "--res",
            "32",
            "--out",
            &o("v.binvox"),
            "--trace",
            &o("tr.json"),
        ],
        vec![
            "voxelize",
            &suzanne,
            "--res",
            "32",
            "--method",
            "abuffer",
            "--out",
            &o("v.vox"),
        ],
        vec![
            "voxelize",
            &cube,
            "--res",
            "16",
            "--gregory-level",
            "4",
            "--out",
            &o("g.npy"),
        ],
        vec![
            "voxelize",
            &cube,
            "--res",
            "16",
            "--method",
            "cpu",
            "--out",
            &o("c.nrrd"),
        ],
        vec![
            "demo",
            "--offscreen",
            "--scene",
            "cage",
            "--frames",
            "3",
            "--size",
            "64x48",
            "--out",
            &o("d"),
        ],
        vec![
            "demo",
            "--offscreen",
            "--scene",
            "flag",
            "--frames",
            "3",
            "--size",
            "64x48",
            "--out",
            &o("d"),
        ],
        vec![
            "demo",
            "--offscreen",
            "--scene",
            "spinner",
            "--frames",
            "3",
            "--size",
            "64x48",
            "--out",
            &o("d"),
        ],
    ]
    .into_iter()
    .map(|a| a.into_iter().map(String::from).collect())
    .collect();
    for args in runs {
        let out = gregvox(&args);
        assert_success(&args.join(" "), &out);
    }
    assert!(dir.files().iter().all(|f| !f.contains(".tmp")));
}

#[test]
fn an_allocation_budget_gives_a_clear_out_of_memory_error() {
    let dir = Scratch::new("budget");
    let suzanne = model("suzanne.obj");
    let cube = model("opensubdiv/catmark_cube.obj");
    let budget = [("GREGVOX_MEMORY_BUDGET", "8M")];
    let vox = dir.path("v.binvox");
    let out = gregvox_env(
        &[
            "voxelize",
            &suzanne,
            "--res",
            "512",
            "--method",
            "peel",
            "--out",
            &s(&vox),
        ],
        &budget,
    );
    assert_clear_failure(
        "voxelize 512 in 8M",
        &out,
        "GPU memory allocation",
        "over the memory budget of 8388608 bytes",
    );
    assert!(stderr(&out).contains("GREGVOX_MEMORY_BUDGET"));
    let out = gregvox_env(
        &[
            "tessellate",
            &cube,
            "--level",
            "64",
            "--out",
            &s(&dir.path("t.obj")),
        ],
        &[("GREGVOX_MEMORY_BUDGET", "1M")],
    );
    assert_clear_failure(
        "tessellate 64 in 1M",
        &out,
        "GPU memory allocation",
        "memory budget",
    );
    let out = gregvox_env(
        &[
            "demo",
            "--offscreen",
            "--scene",
            "flag",
            "--frames",
            "2",
            "--out",
            &s(&dir.path("d")),
        ],
        &[("GREGVOX_MEMORY_BUDGET", "1M")],
    );
    assert_clear_failure("demo in 1M", &out, "GPU memory allocation", "memory budget");
    // A generous budget changes nothing.
    let out = gregvox_env(
        &["voxelize", &suzanne, "--res", "32", "--out", &s(&vox)],
        &[("GREGVOX_MEMORY_BUDGET", "1G")],
    );
    assert_success("voxelize 32 in 1G", &out);
    std::fs::remove_file(&vox).unwrap();
    // A malformed budget names the variable (on a command that creates a device).
    let out = gregvox_env(
        &["voxelize", &suzanne, "--res", "8", "--method", "peel"],
        &[("GREGVOX_MEMORY_BUDGET", "lots")],
    );
    assert_clear_failure(
        "budget 'lots'",
        &out,
        "GREGVOX_MEMORY_BUDGET='lots'",
        "is not a memory size",
    );
    assert!(dir.files().is_empty(), "outputs left: {:?}", dir.files());
}
