//! OBJ loading contract: positions as given (f64, file order, unreferenced kept), polygons kept, and one
//! clear error naming the file and the line for every kind of bad input, never a panic.
mod mesh_common;
use gregvox::mesh::{load_obj, parse_obj, write_obj, Mesh};
use gregvox::Error;
use mesh_common::model;
use std::path::PathBuf;

fn tmp(name: &str, content: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("gregvox-mesh-loading-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, content).unwrap();
    p
}

/// Loads text from a temp file and returns the error message (which must name the file).
fn error_of(name: &str, content: &[u8]) -> String {
    let p = tmp(name, content);
    let e = load_obj(&p).expect_err("bad input must be an error");
    let msg = e.to_string();
    assert!(msg.contains(name), "message names the file: {msg}");
    assert!(matches!(e, Error::Parse { .. } | Error::Io { .. }), "{e:?}");
    msg
}

#[test]
fn bunny_positions_are_kept_as_given_with_unreferenced_vertices() {
    let mesh = load_obj(model("stanford-bunny.obj")).unwrap();
    assert_eq!((mesh.positions.len(), mesh.n_faces()), (35947, 69451));
    // first v line of the file, read as f64 (no f32 rounding)
    let text = std::fs::read_to_string(model("stanford-bunny.obj")).unwrap();
    let first = text.lines().find(|l| l.starts_with("v ")).unwrap();
    let c: Vec<f64> = first
        .split_whitespace()
        .skip(1)
        .map(|t| t.parse().unwrap())
        .collect();
    assert_eq!(mesh.positions[0].to_array(), [c[0], c[1], c[2]]);
}

#[test]
fn polygons_are_kept_not_triangulated() {
    let mesh = load_obj(model("spot_control_mesh.obj")).unwrap();
    let mut orders = [0usize; 8];
    for f in 0..mesh.n_faces() {
        orders[mesh.face(f).len()] += 1;
    }
    assert_eq!((orders[3], orders[4], orders[5]), (4, 160, 16));
}

#[test]
fn slash_forms_relative_indices_and_other_statements_are_read() {
    let text =
        "# comment\nmtllib x.mtl\no thing\nv 0 0 0\nv 1 0 0 1.0\nv 1 1 0 0.5 0.5 0.5\nv 0 1 0\n\
vt 0 0\nvn 0 0 1\ng g1\ns off\nusemtl m\nf 1/1/1 2//1 3/1 -1\nl 1 2\n";
    let m = parse_obj(text, "forms.obj").unwrap();
    assert_eq!(m.face(0), &[0, 1, 2, 3]);
    assert_eq!(m.positions.len(), 4);
}

#[test]
fn missing_file_names_the_file() {
    let e = load_obj("/nonexistent/dir/missing-mesh.obj")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("missing-mesh.obj") && e.contains("No such file"),
        "{e}"
    );
}

#[test]
fn a_directory_is_an_io_error() {
    let dir = std::env::temp_dir();
    let e = load_obj(&dir).unwrap_err();
    assert!(matches!(e, Error::Io { .. }), "{e:?}");
}

#[test]
fn parse_error_names_the_line() {
    let msg = error_of("parse.obj", b"v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n");
    assert!(msg.contains("line 2") && msg.contains("zero"), "{msg}");
    let msg = error_of("short.obj", b"v 0 0\n");
    assert!(
        msg.contains("line 1") && msg.contains("2 coordinates"),
        "{msg}"
    );
    let msg = error_of("badface.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n");
    assert!(msg.contains("line 4") && msg.contains("'x'"), "{msg}");
}

#[test]
fn index_out_of_range_names_the_line_and_index() {
    let msg = error_of(
        "range.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n",
    );
    assert!(
        msg.contains("line 5") && msg.contains("index 9") && msg.contains("3 vertices"),
        "{msg}"
    );
}

#[test]
fn zero_and_too_negative_indices_are_errors() {
    let msg = error_of("zero.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
    assert!(msg.contains("line 4") && msg.contains("index 0"), "{msg}");
    let msg = error_of("neg.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n");
    assert!(msg.contains("line 4") && msg.contains("-4"), "{msg}");
}

#[test]
fn nan_and_inf_coordinates_are_errors() {
    let msg = error_of("nan.obj", b"v 0 0 0\nv 1 NaN 0\nv 0 1 0\nf 1 2 3\n");
    assert!(
        msg.contains("line 2") && msg.contains("vertex 2") && msg.contains("non-finite"),
        "{msg}"
    );
    let msg = error_of("inf.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 -inf\nf 1 2 3\n");
    assert!(
        msg.contains("line 3") && msg.contains("non-finite"),
        "{msg}"
    );
    let msg = error_of("huge.obj", b"v 1e400 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    assert!(msg.contains("line 1"), "{msg}");
}

#[test]
fn faces_with_fewer_than_three_vertices_are_errors() {
    let msg = error_of("two.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n");
    assert!(
        msg.contains("line 4") && msg.contains("2 vertices"),
        "{msg}"
    );
    let msg = error_of("rep.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 2\n");
    assert!(msg.contains("line 4") && msg.contains("twice"), "{msg}");
}

#[test]
fn empty_meshes_are_errors() {
    let msg = error_of("empty.obj", b"");
    assert!(msg.contains("empty mesh"), "{msg}");
    let msg = error_of("comments.obj", b"# nothing here\n\n");
    assert!(msg.contains("empty mesh"), "{msg}");
    let msg = error_of("points.obj", b"v 0 0 0\nv 1 0 0\n");
    assert!(msg.contains("2 vertices but no faces"), "{msg}");
}

#[test]
fn binary_garbage_is_an_error_not_a_panic() {
    let mut garbage: Vec<u8> = (0..4096u32)
        .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
        .collect();
    garbage[10] = 0;
    let msg = error_of("garbage.obj", &garbage);
    assert!(msg.contains("binary") || msg.contains("UTF-8"), "{msg}");
    let msg = error_of("latin1.obj", b"v 0 0 0\n# caf\xe9\n");
    assert!(msg.contains("line 2") && msg.contains("UTF-8"), "{msg}");
}

#[test]
fn write_then_read_is_exact() {
    let mesh = load_obj(model("suzanne.obj")).unwrap();
    let p = tmp("roundtrip.obj", b"");
    write_obj(&p, &mesh).unwrap();
    let back: Mesh = load_obj(&p).unwrap();
    assert_eq!(back, mesh);
    // no temporary file is left beside the output
    let leftovers: Vec<_> = std::fs::read_dir(p.parent().unwrap())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty());
}

#[test]
fn writing_into_a_missing_directory_is_an_io_error() {
    let mesh = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "t.obj").unwrap();
    let e = write_obj("/nonexistent/dir/out.obj", &mesh)
        .unwrap_err()
        .to_string();
    assert!(e.contains("out.obj"), "{e}");
}

#[test]
fn exact_welding_merges_signed_zeros_and_keeps_unreferenced_vertices() {
    let m = parse_obj(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv -0 -0 0\nv 1 -0 0\nv 0 0 1\nv 9 9 9\nf 1 2 3\nf 4 6 5\n",
        "w.obj",
    )
    .unwrap();
    let (w, map) = gregvox::mesh::weld(&m, 0.0);
    assert_eq!(map, vec![0, 1, 2, 0, 1, 3, 4]);
    assert_eq!(
        w.positions.len(),
        5,
        "the unreferenced vertex (9,9,9) is kept"
    );
    assert_eq!(w.face(1), &[0, 3, 1]);
}
