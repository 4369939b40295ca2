//! Every mesh format gregvox reads, on files written by other tools (`tests/fixtures/mesh_formats/`,
//! written by trimesh and plyfile: see its README.md), and on hostile files made here: truncated, lying
//! counts, NaN, out-of-range indices, empty meshes, GLB container and glTF structure errors; and the
//! `.gzjson` compression bomb.
use glam::DVec3;
use gregvox::mesh::{load_mesh_file, Mesh};
use gregvox::{voxelize_on_cpu, VoxelizeOptions};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// The fixtures that hold the mesh itself (m_moved.glb holds it moved).
const SAME_MESH: [&str; 10] = [
    "m.obj",
    "m_ascii.stl",
    "m_binary.stl",
    "m_ascii.ply",
    "m_le.ply",
    "m_be.ply",
    "m.off",
    "m.glb",
    "m.gltf",
    "m_embedded.gltf",
];

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/mesh_formats")
        .join(name)
}

fn load(name: &str) -> Mesh {
    load_mesh_file(fixture(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// A scratch folder removed at the end of the test.
struct Scratch(PathBuf);

impl Scratch {
    fn new(tag: &str) -> Scratch {
        let d =
            std::env::temp_dir().join(format!("gregvox-mesh-formats-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        Scratch(d)
    }
    fn write(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let p = self.0.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A position as exact bits (-0.0 as 0.0).
type Key = [u64; 3];

fn key(p: DVec3) -> Key {
    [
        (p.x + 0.0).to_bits(),
        (p.y + 0.0).to_bits(),
        (p.z + 0.0).to_bits(),
    ]
}

/// The mesh up to vertex renumbering: its positions as a sorted list, and its faces as position lists
/// rotated to start at the smallest (winding kept), sorted.
fn canonical(m: &Mesh) -> (Vec<Key>, Vec<Vec<Key>>) {
    let mut pos: Vec<Key> = m.positions.iter().map(|&p| key(p)).collect();
    pos.sort();
    let mut faces: Vec<Vec<Key>> = (0..m.n_faces())
        .map(|f| {
            let mut k: Vec<Key> = m
                .face(f)
                .iter()
                .map(|&v| key(m.positions[v as usize]))
                .collect();
            let min = (0..k.len()).min_by_key(|&i| k[i]).unwrap();
            k.rotate_left(min);
            k
        })
        .collect();
    faces.sort();
    (pos, faces)
}

#[test]
fn every_format_of_the_same_mesh_gives_the_same_mesh_after_welding() {
    let reference = load("m.obj");
    assert_eq!((reference.positions.len(), reference.n_faces()), (505, 968));
    let want = canonical(&reference);
    for name in SAME_MESH {
        let m = load(name);
        assert_eq!(
            (m.positions.len(), m.n_faces()),
            (505, 968),
            "{name}: vertex and face counts"
        );
        assert!(canonical(&m) == want, "{name}: not the same mesh as m.obj");
    }
}

#[test]
fn stl_and_gltf_are_welded_but_obj_ply_off_keep_their_vertices_in_file_order() {
    // OBJ, PLY and OFF of the same vertex list give the very same mesh, numbering included.
    let obj = load("m.obj");
    for name in ["m_ascii.ply", "m_le.ply", "m_be.ply", "m.off"] {
        assert!(load(name) == obj, "{name}: not identical to m.obj");
    }
    // The GLB holds two parts with their own copies of the seam vertices: 543 stored, 505 once welded.
    let glb = std::fs::read(fixture("m.glb")).unwrap();
    let n = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let doc: Value = serde_json::from_slice(&glb[20..20 + n]).unwrap();
    let stored: u64 = doc["meshes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            doc["accessors"][m["primitives"][0]["attributes"]["POSITION"]
                .as_u64()
                .unwrap() as usize]["count"]
                .as_u64()
                .unwrap()
        })
        .sum();
    assert_eq!(stored, 543);
    assert_eq!(load("m.glb").positions.len(), 505);
}

fn gregvox(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_gregvox"))
        .args(args)
        .output()
        .expect("gregvox runs")
}

fn mesh_json(path: &Path) -> Value {
    let out = gregvox(&["mesh", path.to_str().unwrap(), "--json"]);
    assert!(
        out.status.success(),
        "{}: {}",
        path.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("stdout is one JSON document")
}

#[test]
fn every_format_gives_the_same_mesh_json_report_as_the_obj() {
    let want = mesh_json(&fixture("m.obj"));
    // The mesh is open: boundaries and components matter.
    assert_eq!(want["closed"], false);
    assert!(want["boundary_edges"].as_u64().unwrap() > 0);
    assert_eq!(want["unreferenced_vertices"], 0);
    for name in SAME_MESH {
        assert_eq!(mesh_json(&fixture(name)), want, "{name}");
    }
}

#[test]
fn every_format_gives_the_same_cpu_voxels_at_res_32() {
    let opts = VoxelizeOptions::default().res(32);
    let want = voxelize_on_cpu(&load("m.obj"), &opts).unwrap().grid;
    assert!(want.words.iter().any(|&w| w != 0), "some voxel is set");
    for name in SAME_MESH {
        let got = voxelize_on_cpu(&load(name), &opts).unwrap().grid;
        assert!(got == want, "{name}: voxel grids differ");
    }
}

#[test]
fn moved_glb_is_the_mesh_under_its_node_transforms_exactly() {
    // Parent node: scale 2; child: translation (4, -2, 1); world: 2p + (8, -4, 2), exact in f64.
    let mut m = load("m.obj");
    for p in &mut m.positions {
        *p = 2.0 * *p + DVec3::new(8.0, -4.0, 2.0);
    }
    assert!(canonical(&load("m_moved.glb")) == canonical(&m));
    // The same occupancy, voxel for voxel, in a grid scaled and moved the same way (exact: powers of two).
    let opts = VoxelizeOptions::default().res(32);
    let here = voxelize_on_cpu(&load("m.obj"), &opts).unwrap().grid;
    let moved = voxelize_on_cpu(&load("m_moved.glb"), &opts).unwrap().grid;
    assert_eq!(moved.words, here.words);
    for a in 0..3 {
        let t = [8.0, -4.0, 2.0][a];
        assert_eq!(moved.frame.origin[a], 2.0 * here.frame.origin[a] + t);
        assert_eq!(moved.frame.voxel_size[a], 2.0 * here.frame.voxel_size[a]);
    }
}

#[test]
fn binary_stl_whose_header_starts_with_solid_is_read_as_binary() {
    let dir = Scratch::new("solid-header");
    let mut b = std::fs::read(fixture("m_binary.stl")).unwrap();
    b[..80].fill(b' ');
    b[..24].copy_from_slice(b"solid exported by a CAD ");
    let p = dir.write("solid_header.stl", &b);
    assert!(canonical(&load_mesh_file(&p).unwrap()) == canonical(&load("m.obj")));
    // Detection is by content: the same bytes under another name are still binary STL.
    let q = dir.write("solid_header.dat", &b);
    assert!(canonical(&load_mesh_file(&q).unwrap()) == canonical(&load("m.obj")));
}

#[test]
fn formats_are_detected_by_content_whatever_the_extension() {
    let dir = Scratch::new("detect");
    let want = canonical(&load("m.obj"));
    for name in [
        "m_ascii.stl",
        "m_binary.stl",
        "m_ascii.ply",
        "m_be.ply",
        "m.off",
        "m.glb",
    ] {
        let p = dir.write(
            &format!("{name}.model"),
            &std::fs::read(fixture(name)).unwrap(),
        );
        assert!(
            canonical(&load_mesh_file(&p).unwrap()) == want,
            "{name} renamed"
        );
    }
    // OBJ text under another name still reads as OBJ (the fallback).
    let p = dir.write("m.txt", &std::fs::read(fixture("m.obj")).unwrap());
    assert!(canonical(&load_mesh_file(&p).unwrap()) == want);
}

#[test]
fn gregvox_voxelize_reports_the_same_for_obj_ply_and_glb() {
    // `gregvox voxelize` on a PLY and a GLB gives what it gives on the OBJ.
    let dir = Scratch::new("cli");
    let mut outs = Vec::new();
    for name in ["m.obj", "m_be.ply", "m.glb"] {
        let out = dir.0.join(format!("{name}.json"));
        let o = gregvox(&[
            "voxelize",
            fixture(name).to_str().unwrap(),
            "--method",
            "cpu",
            "--res",
            "16",
            "--json",
        ]);
        assert!(
            o.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let _ = out;
        let mut j: Value = serde_json::from_slice(&o.stdout).expect("one JSON document");
        if let Some(obj) = j.as_object_mut() {
            obj.remove("input");
            obj.remove("seconds");
            obj.remove("timings");
        }
        outs.push(j);
    }
    assert_eq!(outs[0], outs[1]);
    assert_eq!(outs[0], outs[2]);
}

// ---------------------------------------------------------------------------------------------------------
// Hostile files

/// Loads `bytes` saved as `name` and returns the one-line error, which must name the file and contain
/// every piece of `expect`.
fn refused(dir: &Scratch, name: &str, bytes: &[u8], expect: &[&str]) -> String {
    let p = dir.write(name, bytes);
    let start = Instant::now();
    let r = std::panic::catch_unwind(|| load_mesh_file(&p));
    let elapsed = start.elapsed();
    let err = match r {
        Err(_) => panic!("{name}: the loader panicked"),
        Ok(Ok(m)) => panic!(
            "{name}: accepted ({} vertices, {} faces)",
            m.positions.len(),
            m.n_faces()
        ),
        Ok(Err(e)) => e.to_string(),
    };
    assert!(
        err.starts_with(&p.display().to_string()),
        "{name}: the error does not start with the file: {err}"
    );
    assert!(!err.contains('\n'), "{name}: one line: {err}");
    for piece in expect {
        assert!(err.contains(piece), "{name}: '{piece}' not in: {err}");
    }
    assert!(elapsed < Duration::from_secs(2), "{name}: took {elapsed:?}");
    err
}

fn binary_stl(tris: &[[[f32; 3]; 3]], claimed: u32) -> Vec<u8> {
    let mut b = vec![0u8; 80];
    b.extend_from_slice(&claimed.to_le_bytes());
    for t in tris {
        b.extend_from_slice(&[0u8; 12]);
        for c in t {
            for x in c {
                b.extend_from_slice(&x.to_le_bytes());
            }
        }
        b.extend_from_slice(&[0u8; 2]);
    }
    b
}

const TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

#[test]
fn hostile_binary_stl_files_are_refused_with_the_byte_offset() {
    let d = Scratch::new("stl-bin");
    let fixture_bytes = std::fs::read(fixture("m_binary.stl")).unwrap();
    refused(
        &d,
        "trunc.stl",
        &fixture_bytes[..1000],
        &[
            "byte 80",
            "claims 968 triangles",
            "48484 bytes",
            "has 1000",
            "truncated",
        ],
    );
    refused(
        &d,
        "header.stl",
        &fixture_bytes[..50],
        &["byte 50", "84-byte binary STL header"],
    );
    refused(
        &d,
        "empty.stl",
        &binary_stl(&[], 0),
        &["byte 80", "empty mesh"],
    );
    refused(&d, "zero.stl", b"", &["byte 0", "header"]);
    let mut nan = TRI;
    nan[1][2] = f32::NAN;
    refused(
        &d,
        "nan.stl",
        &binary_stl(&[TRI, nan], 2),
        &["byte 158", "triangle 2 corner 2", "non-finite", "NaN"],
    );
    let mut inf = TRI;
    inf[2][0] = f32::INFINITY;
    refused(
        &d,
        "inf.stl",
        &binary_stl(&[inf], 1),
        &["triangle 1 corner 3", "inf"],
    );
    // A sliver with two corners at the same position is dropped (real exports carry them); only a mesh of
    // nothing else is refused.
    let mut degenerate = TRI;
    degenerate[2] = degenerate[0];
    let m = load_mesh_file(d.write("sliver.stl", &binary_stl(&[TRI, degenerate], 2))).unwrap();
    assert_eq!((m.n_faces(), m.positions.len()), (1, 3));
    refused(
        &d,
        "degenerate.stl",
        &binary_stl(&[degenerate, degenerate], 2),
        &["empty mesh", "every triangle is degenerate"],
    );
}

#[test]
fn stl_claiming_a_billion_triangles_in_a_kilobyte_is_refused_before_allocating() {
    let d = Scratch::new("stl-liar");
    let mut b = binary_stl(&[TRI; 20], 1_000_000_000);
    b.truncate(1024);
    refused(
        &d,
        "liar.stl",
        &b,
        &[
            "byte 80",
            "claims 1000000000 triangles",
            "50000000084 bytes",
            "has 1024",
        ],
    );
}

#[test]
fn hostile_ascii_stl_files_are_refused_with_the_line() {
    let d = Scratch::new("stl-ascii");
    let facet = |v: &str| {
        format!("facet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n  vertex {v}\n endloop\nendfacet\n")
    };
    let ok = format!("solid t\n{}endsolid t\n", facet("0 1 0"));
    assert!(load_mesh_file(d.write("ok.stl", ok.as_bytes())).is_ok());
    refused(
        &d,
        "no-end.stl",
        format!("solid t\n{}", facet("0 1 0")).as_bytes(),
        &["line 8", "no 'endsolid'"],
    );
    refused(
        &d,
        "nan.stl",
        format!("solid t\n{}endsolid\n", facet("0 nan 0")).as_bytes(),
        &["line 6", "triangle 1 corner 3", "NaN"],
    );
    refused(
        &d,
        "word.stl",
        format!("solid t\n{}endsolid\n", facet("0 one 0")).as_bytes(),
        &["line 6", "cannot read vertex coordinate 'one'"],
    );
    refused(
        &d,
        "two.stl",
        b"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\n",
        &["line 6", "expected 'vertex', found 'endloop'"],
    );
    refused(&d, "empty.stl", b"solid t\nendsolid t\n", &["empty mesh"]);
    refused(
        &d,
        "degenerate.stl",
        format!("solid t\n{}endsolid\n", facet("1 0 0")).as_bytes(),
        &["empty mesh", "every triangle is degenerate"],
    );
}

/// A PLY with the given header body lines and data.
fn ply(format: &str, header: &str, data: &[u8]) -> Vec<u8> {
    let mut b = format!("ply\nformat {format} 1.0\n{header}end_header\n").into_bytes();
    b.extend_from_slice(data);
    b
}

const PLY_HEADER: &str = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n";

#[test]
fn hostile_ply_files_are_refused_with_the_line_or_byte() {
    let d = Scratch::new("ply");
    let good = ply("ascii", PLY_HEADER, b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    assert!(load_mesh_file(d.write("ok.ply", &good)).is_ok());
    refused(
        &d,
        "nan.ply",
        &ply("ascii", PLY_HEADER, b"0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n"),
        &["line 11", "vertex 1 has a non-finite coordinate (NaN)"],
    );
    refused(
        &d,
        "range.ply",
        &ply("ascii", PLY_HEADER, b"0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"),
        &["line 13", "face 0: vertex index 3 is out of range"],
    );
    refused(
        &d,
        "negative.ply",
        &ply("ascii", PLY_HEADER, b"0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n"),
        &["line 13", "vertex index -1"],
    );
    refused(
        &d,
        "two.ply",
        &ply("ascii", PLY_HEADER, b"0 0 0\n1 0 0\n0 1 0\n2 0 1\n"),
        &["line 13", "face 0: has 2 vertices"],
    );
    refused(
        &d,
        "twice.ply",
        &ply("ascii", PLY_HEADER, b"0 0 0\n1 0 0\n0 1 0\n3 0 1 1\n"),
        &["line 13", "vertex 1 appears twice"],
    );
    refused(
        &d,
        "short.ply",
        &ply("ascii", PLY_HEADER, b"0 0 0\n1 0\n0 1 0\n3 0 1 2\n"),
        &["line 11", "fewer values"],
    );
    refused(
        &d,
        "trunc.ply",
        &ply("ascii", PLY_HEADER, b"0 0 0\n1 0 0\n0 1 0\n"),
        &["line 10", "need at least 10 values", "only 18 bytes follow"],
    );
    refused(
        &d,
        "trunc2.ply",
        &ply("ascii", PLY_HEADER, b"0 0 0\n1 0 0\n0 1 0\n\n\n\n"),
        &["line 15", "face 0", "file ends"],
    );
    refused(
        &d,
        "extra.ply",
        &ply(
            "ascii",
            PLY_HEADER,
            b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n",
        ),
        &["line 14", "after the last element"],
    );
    refused(
        &d,
        "no-faces.ply",
        &ply(
            "ascii",
            "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n",
            b"0 0 0\n",
        ),
        &["empty mesh", "no 'face' element"],
    );
    refused(
        &d,
        "zero-faces.ply",
        &ply(
            "ascii",
            &PLY_HEADER.replace("face 1", "face 0"),
            b"0 0 0\n1 0 0\n0 1 0\n",
        ),
        &["line 7", "empty mesh: 0 faces"],
    );
    refused(
        &d,
        "huge-count.ply",
        &ply(
            "ascii",
            &PLY_HEADER.replace("vertex 3", "vertex 99999999999999999999999"),
            b"",
        ),
        &["line 3", "cannot read the count"],
    );
    refused(
        &d,
        "no-end.ply",
        b"ply\nformat ascii 1.0\nelement vertex 3\n",
        &["line 4", "no 'end_header'"],
    );
    refused(
        &d,
        "format.ply",
        &ply("binary_middle_endian", PLY_HEADER, b""),
        &["line 2", "unknown PLY format"],
    );
    refused(
        &d,
        "type.ply",
        &ply("ascii", &PLY_HEADER.replace("float y", "quad y"), b""),
        &["line 5", "unknown property type 'quad'"],
    );
    refused(
        &d,
        "no-z.ply",
        &ply("ascii", &PLY_HEADER.replace("float z", "float w"), b""),
        &["line 3", "no 'z' property"],
    );
    // Binary: truncated data and lying lists name the byte.
    let mut bin = Vec::new();
    for v in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]] {
        for x in v {
            bin.extend_from_slice(&x.to_le_bytes());
        }
    }
    bin.push(3);
    for i in [0i32, 1, 2] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let good = ply("binary_little_endian", PLY_HEADER, &bin);
    assert!(load_mesh_file(d.write("ok-bin.ply", &good)).is_ok());
    let body = good.len() - bin.len();
    let mut long_list = good.clone();
    long_list[body + 36] = 200; // a 200-corner face in a file with 12 bytes left
    refused(
        &d,
        "list.ply",
        &long_list,
        &[
            &format!("byte {}", body + 49),
            "face 0",
            "file ends inside the data",
        ],
    );
    // Lists are empty in the fixed size: 3 × 12 bytes of vertices and a 1-byte count.
    refused(
        &d,
        "trunc-bin.ply",
        &good[..body + 30],
        &[
            &format!("byte {body}"),
            "which need at least 37 bytes",
            "only 30 bytes follow",
        ],
    );
    refused(
        &d,
        "trunc-list.ply",
        &good[..good.len() - 3],
        &[
            &format!("byte {}", body + 45),
            "face 0",
            "file ends inside the data",
        ],
    );
    let mut nan = good.clone();
    nan[body + 16..body + 20].copy_from_slice(&f32::NAN.to_le_bytes());
    refused(
        &d,
        "nan-bin.ply",
        &nan,
        &[
            &format!("byte {}", body + 12),
            "vertex 1 has a non-finite coordinate (NaN)",
        ],
    );
    let mut range = good.clone();
    range[body + 45..body + 49].copy_from_slice(&7i32.to_le_bytes());
    refused(
        &d,
        "range-bin.ply",
        &range,
        &[
            &format!("byte {}", body + 36),
            "face 0: vertex index 7 is out of range",
        ],
    );
    let mut extra = good.clone();
    extra.extend_from_slice(&[0; 5]);
    refused(
        &d,
        "extra-bin.ply",
        &extra,
        &["5 bytes after the last element"],
    );
}

#[test]
fn ply_reads_integer_coordinates_any_list_types_and_reads_past_float_lists() {
    let d = Scratch::new("ply-types");
    let header = "element vertex 3\nproperty short x\nproperty int y\nproperty uchar z\n\
                  element face 1\nproperty list ushort float texcoord\nproperty list uint ushort vertex_index\n\
                  element edge 1\nproperty int a\n";
    let want = Mesh::from_polygons(
        vec![
            DVec3::new(-2.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 7.0),
            DVec3::new(0.0, 1.0, 0.0),
        ],
        &[vec![0, 1, 2]],
    )
    .unwrap();
    let ascii = ply(
        "ascii",
        header,
        b"-2 0 0\n1 0 7\n0 1 0\n3 0.5 0.5 0.25 3 0 1 2\n9\n",
    );
    assert_eq!(load_mesh_file(d.write("a.ply", &ascii)).unwrap(), want);
    for (format, big) in [("binary_little_endian", false), ("binary_big_endian", true)] {
        let mut b = Vec::new();
        let mut put = |bytes: &[u8]| {
            let mut v = bytes.to_vec();
            if big {
                v.reverse();
            }
            b.extend_from_slice(&v);
        };
        for (x, y, z) in [(-2i16, 0i32, 0u8), (1, 0, 7), (0, 1, 0)] {
            put(&x.to_le_bytes());
            put(&y.to_le_bytes());
            put(&z.to_le_bytes());
        }
        put(&3u16.to_le_bytes());
        for t in [0.5f32, 0.5, 0.25] {
            put(&t.to_le_bytes());
        }
        put(&3u32.to_le_bytes());
        for i in [0u16, 1, 2] {
            put(&i.to_le_bytes());
        }
        put(&9i32.to_le_bytes());
        let m =
            load_mesh_file(d.write(&format!("{format}.ply"), &ply(format, header, &b))).unwrap();
        assert_eq!(m, want, "{format}");
    }
}

#[test]
fn ply_claiming_a_billion_faces_in_a_kilobyte_is_refused_before_allocating() {
    let d = Scratch::new("ply-liar");
    for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
        let header = PLY_HEADER.replace("face 1", "face 1000000000");
        let mut b = ply(format, &header, &[b'0'; 1024]);
        b.truncate(1024);
        refused(
            &d,
            &format!("liar-{format}.ply"),
            &b,
            &[
                "claims 3 vertex, 1000000000 face",
                "which need at least",
                "follow the header",
            ],
        );
        let header = PLY_HEADER.replace("vertex 3", "vertex 4000000000");
        refused(
            &d,
            &format!("liar-v-{format}.ply"),
            &ply(format, &header, &[b'0'; 800]),
            &["claims 4000000000 vertex"],
        );
    }
}

#[test]
fn hostile_off_files_are_refused_with_the_line() {
    let d = Scratch::new("off");
    assert!(load_mesh_file(d.write(
        "ok.off",
        b"OFF\n# a comment\n3 1 0\n0 0 0\n1 0 0 # x\n0 1 0\n3 0 1 2\n"
    ))
    .is_ok());
    assert!(load_mesh_file(d.write(
        "counts-on-first.off",
        b"OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 255 0 0\n"
    ))
    .is_ok());
    assert!(load_mesh_file(d.write(
        "coff.off",
        b"COFF\n3 1 0\n0 0 0 1 1 1 1\n1 0 0 1 1 1 1\n0 1 0 1 1 1 1\n3 0 1 2\n"
    ))
    .is_ok());
    refused(
        &d,
        "liar.off",
        b"OFF\n1000000000 1000000000 0\n0 0 0\n",
        &[
            "line 2",
            "claims 1000000000 vertices and 1000000000 faces",
            "only 6 bytes follow",
        ],
    );
    refused(
        &d,
        "nan.off",
        b"OFF\n3 1 0\n0 0 0\n1 0 inf\n0 1 0\n3 0 1 2\n",
        &["line 4", "vertex 1 has a non-finite coordinate (inf)"],
    );
    refused(
        &d,
        "range.off",
        b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
        &["line 6", "face 0: vertex index 3 is out of range"],
    );
    refused(
        &d,
        "two.off",
        b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1     \n",
        &["line 6", "has 2 vertices"],
    );
    refused(
        &d,
        "twice.off",
        b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 0   \n",
        &["line 6", "appears twice"],
    );
    refused(
        &d,
        "short-face.off",
        b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2   \n",
        &["line 6", "has 3 of the 4 vertex indices"],
    );
    refused(
        &d,
        "trunc2.off",
        b"OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2         \n",
        &["file ends after 1 of the 2 faces"],
    );
    refused(&d, "empty.off", b"OFF\n0 0 0\n", &["line 2", "empty mesh"]);
    refused(
        &d,
        "no-faces.off",
        b"OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n",
        &["line 2", "empty mesh: 3 vertices but 0 faces"],
    );
    refused(&d, "4d.off", b"4OFF\n3 1 0\n", &["line 1", "only 3-D"]);
    refused(&d, "binary.off", b"OFF BINARY\n", &["line 1", "binary OFF"]);
    refused(
        &d,
        "extra.off",
        b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n",
        &["line 7", "data after the last face"],
    );
}

#[test]
fn empty_and_blank_files_of_every_extension_are_refused() {
    let d = Scratch::new("empty");
    for ext in ["obj", "stl", "ply", "off", "gltf", "glb", "bin"] {
        refused(&d, &format!("empty.{ext}"), b"", &[]);
        refused(&d, &format!("blank.{ext}"), b"\n\n  \n", &[]);
    }
}

// glTF ----------------------------------------------------------------------------------------------------

/// The fixture GLB's JSON and BIN chunk.
fn glb_parts() -> (Value, Vec<u8>) {
    let b = std::fs::read(fixture("m.glb")).unwrap();
    let n = u32::from_le_bytes(b[12..16].try_into().unwrap()) as usize;
    let json = serde_json::from_slice(&b[20..20 + n]).unwrap();
    let bn = u32::from_le_bytes(b[20 + n..24 + n].try_into().unwrap()) as usize;
    (json, b[28 + n..28 + n + bn].to_vec())
}

/// A GLB of `json` and `bin`.
fn glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut j = serde_json::to_vec(json).unwrap();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    let mut bin = bin.to_vec();
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + bin.len();
    let mut b = Vec::new();
    b.extend_from_slice(b"glTF");
    b.extend_from_slice(&2u32.to_le_bytes());
    b.extend_from_slice(&(total as u32).to_le_bytes());
    b.extend_from_slice(&(j.len() as u32).to_le_bytes());
    b.extend_from_slice(&0x4E4F534Au32.to_le_bytes());
    b.extend_from_slice(&j);
    b.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    b.extend_from_slice(&0x004E4942u32.to_le_bytes());
    b.extend_from_slice(&bin);
    b
}

#[test]
fn glb_rebuilt_here_reads_like_the_fixture() {
    let d = Scratch::new("glb-same");
    let (j, bin) = glb_parts();
    let p = d.write("same.glb", &glb(&j, &bin));
    assert!(canonical(&load_mesh_file(&p).unwrap()) == canonical(&load("m.obj")));
}

#[test]
fn hostile_glb_files_are_refused_naming_the_byte_or_the_gltf_object() {
    let d = Scratch::new("glb");
    let (j, bin) = glb_parts();
    let good = glb(&j, &bin);
    // Container.
    refused(
        &d,
        "short.glb",
        &good[..10],
        &["byte 10", "12-byte GLB header"],
    );
    refused(
        &d,
        "length.glb",
        &good[..good.len() - 4],
        &["byte 8", "says the file has"],
    );
    let mut chunk = good.clone();
    chunk[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    refused(
        &d,
        "chunk.glb",
        &chunk,
        &["byte 12", "runs past the end of the file"],
    );
    let mut version = good.clone();
    version[4] = 1;
    refused(&d, "version.glb", &version, &["byte 4", "GLB version 1"]);
    let mut bad_json = good.clone();
    bad_json[20] = b'[';
    refused(&d, "json.glb", &bad_json, &["byte 31", "invalid glTF JSON"]);
    // Structure (validated by the gltf crate).
    let mut e = j.clone();
    e["meshes"][0]["primitives"][0]["indices"] = json!(99);
    refused(
        &d,
        "index.glb",
        &glb(&e, &bin),
        &[
            "invalid glTF",
            "meshes[0].primitives[0].indices",
            "Index out of bounds",
        ],
    );
    // Ranges.
    let mut e = j.clone();
    e["accessors"][1]["count"] = json!(100_000_000u64);
    refused(
        &d,
        "accessor.glb",
        &glb(&e, &bin),
        &[
            "accessor 1 (POSITION of mesh 0 primitive 0)",
            "100000000 elements",
            "but the bufferView has 3372",
        ],
    );
    // An instancing bomb: 20,000 nodes sharing one mesh would load 480 MB from 0.3 MB.
    let mut e = j.clone();
    e["nodes"] = Value::Array((0..20_000).map(|_| json!({"mesh": 0})).collect());
    e["scenes"][0]["nodes"] = json!((0..20_000).collect::<Vec<u32>>());
    refused(
        &d,
        "instances.glb",
        &glb(&e, &bin),
        &[
            "the scene instances 5620000 vertices",
            "refusing so large a mesh",
        ],
    );
    let mut e = j.clone();
    e["bufferViews"][1]["byteOffset"] = json!(18000);
    refused(
        &d,
        "view.glb",
        &glb(&e, &bin),
        &["bufferView 1", "run past the end of buffer 0"],
    );
    let mut e = j.clone();
    e["buffers"][0]["byteLength"] = json!(bin.len() + 100);
    refused(
        &d,
        "buffer.glb",
        &glb(&e, &bin),
        &["buffer 0", "byteLength"],
    );
    // Index values past the vertices.
    let mut b2 = bin.clone();
    b2[0..4].copy_from_slice(&5000u32.to_le_bytes());
    refused(
        &d,
        "value.glb",
        &glb(&j, &b2),
        &[
            "mesh 0 primitive 0: index 0 of accessor 0 is 5000, out of range",
            "281 vertices",
        ],
    );
    // NaN position.
    let pos_off = j["bufferViews"][1]["byteOffset"].as_u64().unwrap() as usize;
    let mut b3 = bin.clone();
    b3[pos_off + 4..pos_off + 8].copy_from_slice(&f32::NAN.to_le_bytes());
    refused(
        &d,
        "nan.glb",
        &glb(&j, &b3),
        &["mesh 0 primitive 0: vertex 0 has a non-finite position"],
    );
    // Repeated index in a triangle.
    let mut b4 = bin.clone();
    b4.copy_within(0..4, 4);
    refused(
        &d,
        "twice.glb",
        &glb(&j, &b4),
        &["mesh 0 primitive 0: triangle 0 names vertex"],
    );
    // Node hierarchy.
    let mut e = j.clone();
    e["nodes"][0]["children"] = json!([1]);
    e["nodes"][1]["children"] = json!([0]);
    refused(
        &d,
        "cycle.glb",
        &glb(&e, &bin),
        &["the node hierarchy has a cycle"],
    );
    let mut e = j.clone();
    e["nodes"] = json!([{"mesh": 0, "children": [2]}, {"mesh": 1, "children": [2]}, {}]);
    refused(
        &d,
        "parents.glb",
        &glb(&e, &bin),
        &["node 2 is a child of both node 0 and node 1"],
    );
    let mut e = j.clone();
    e["nodes"][0]["children"] = json!([0]);
    refused(&d, "self.glb", &glb(&e, &bin), &["node 0"]);
    // Only points and lines.
    let mut e = j.clone();
    e["meshes"][0]["primitives"][0]["mode"] = json!(0);
    e["meshes"][1]["primitives"][0]["mode"] = json!(1);
    refused(
        &d,
        "points.glb",
        &glb(&e, &bin),
        &[
            "empty mesh: no triangle primitive",
            "2 point or line primitives skipped",
        ],
    );
    // Sparse accessors are refused, not misread.
    let mut e = j.clone();
    e["accessors"][1]["sparse"] = json!({"count": 1, "indices": {"bufferView": 0, "componentType": 5125}, "values": {"bufferView": 1}});
    refused(&d, "sparse.glb", &glb(&e, &bin), &["accessor 1", "sparse"]);
    // No BIN chunk.
    let mut nobin = glb(&j, &[]);
    nobin.truncate(nobin.len() - 8);
    let len = nobin.len() as u32;
    nobin[8..12].copy_from_slice(&len.to_le_bytes());
    refused(
        &d,
        "nobin.glb",
        &nobin,
        &["buffer 0 is the GLB's BIN chunk, but the file has none"],
    );
}

#[test]
fn gltf_strips_fans_transforms_and_missing_buffers() {
    let d = Scratch::new("gltf");
    // A unit square as a strip and as a fan, in one buffer given as a data: URI; the fan's node is
    // mirrored (scale -1 in x), which flips its winding back to counter-clockwise seen from +z.
    use base64::Engine;
    let mut buf = Vec::new();
    for p in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.], [1., 1., 0.]] {
        for x in p {
            buf.extend_from_slice(&x.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 3, 3, 3] {
        buf.extend_from_slice(&i.to_le_bytes()); // strip with a degenerate tail
    }
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&buf)
    );
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 5}]}],
        "buffers": [{"byteLength": buf.len(), "uri": uri}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 12}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]},
            {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ]
    });
    let strip = load_mesh_file(d.write("strip.gltf", doc.to_string().as_bytes())).unwrap();
    // Strip triangles (0 1 2) and (2 1 3); the degenerate (3 3 3 …) ones skipped.
    assert_eq!(strip.n_faces(), 2);
    assert_eq!(
        (strip.face(0), strip.face(1)),
        (&[0, 1, 2][..], &[2, 1, 3][..])
    );
    let mut fan = doc.clone();
    fan["meshes"][0]["primitives"][0]["mode"] = json!(6);
    fan["accessors"][1]["count"] = json!(4);
    fan["nodes"][0]["scale"] = json!([-1.0, 1.0, 1.0]);
    let m = load_mesh_file(d.write("fan.gltf", fan.to_string().as_bytes())).unwrap();
    // Fan (1 2 0) and (2 3 0), each reversed by the mirror: (1 0 2) and (2 0 3); x negated.
    assert_eq!((m.face(0), m.face(1)), (&[1, 0, 2][..], &[2, 0, 3][..]));
    assert_eq!(m.positions[1], DVec3::new(-1.0, 0.0, 0.0));
    // No scene: every root node; nested TRS transforms compose parent first.
    let mut tree = doc.clone();
    tree.as_object_mut().unwrap().remove("scene");
    tree.as_object_mut().unwrap().remove("scenes");
    tree["meshes"][0]["primitives"][0]["mode"] = json!(4);
    tree["accessors"][1]["count"] = json!(3);
    tree["nodes"] = json!([
        {"children": [1], "translation": [10.0, 0.0, 0.0]},
        {"mesh": 0, "rotation": [0.0, 0.0, 1.0, 0.0], "scale": [2.0, 2.0, 2.0]}
    ]);
    let m = load_mesh_file(d.write("tree.gltf", tree.to_string().as_bytes())).unwrap();
    // Rotation by π about z, scale 2, then translation by 10 in x: (1,0,0) → (8, 0, 0).
    assert!(
        (m.positions[1] - DVec3::new(8.0, 0.0, 0.0)).length() < 1e-12,
        "{}",
        m.positions[1]
    );
    // Missing and short external buffers.
    let mut ext = doc.clone();
    ext["buffers"][0]["uri"] = json!("no%20such.bin");
    refused(
        &d,
        "missing.gltf",
        ext.to_string().as_bytes(),
        &["buffer 0: cannot read", "no such.bin"],
    );
    d.write("short.bin", &buf[..20]);
    ext["buffers"][0]["uri"] = json!("short.bin");
    refused(
        &d,
        "short.gltf",
        ext.to_string().as_bytes(),
        &[
            "buffer 0",
            "has 20 bytes, but the buffer's byteLength is 60",
        ],
    );
    d.write("ok.bin", &buf);
    ext["buffers"][0]["uri"] = json!("ok.bin");
    assert_eq!(
        load_mesh_file(d.write("ok.gltf", ext.to_string().as_bytes()))
            .unwrap()
            .n_faces(),
        2
    );
    ext["buffers"][0]["uri"] = json!("https://example.invalid/m.bin");
    refused(
        &d,
        "remote.gltf",
        ext.to_string().as_bytes(),
        &["buffer 0", "not a relative file path"],
    );
    let mut bad64 = doc.clone();
    bad64["buffers"][0]["uri"] = json!("data:application/octet-stream;base64,@@@@");
    refused(
        &d,
        "base64.gltf",
        bad64.to_string().as_bytes(),
        &["buffer 0", "invalid base64"],
    );
    // An empty accessor with an offset: no triangle, no panic.
    let mut empty = doc.clone();
    empty["accessors"][0]["count"] = json!(0);
    empty["accessors"][0]["byteOffset"] = json!(4);
    empty["meshes"][0]["primitives"][0]
        .as_object_mut()
        .unwrap()
        .remove("indices");
    refused(
        &d,
        "empty.gltf",
        empty.to_string().as_bytes(),
        &["empty mesh"],
    );
    refused(
        &d,
        "syntax.gltf",
        b"{\n  \"asset\": {\"version\": \"2.0\"},\n  \"nodes\": [\n",
        &["line 4", "invalid glTF JSON"],
    );
}

// ---------------------------------------------------------------------------------------------------------
// Truncation at every 1/50 of every fixture

#[test]
fn every_fixture_truncated_at_every_fiftieth_is_refused_or_read_never_a_panic() {
    let d = Scratch::new("truncate");
    let mut names: Vec<&str> = SAME_MESH.to_vec();
    names.push("m_moved.glb");
    for name in names {
        let bytes = std::fs::read(fixture(name)).unwrap();
        // Binary files and glTF JSON can never be cut and still be whole; text formats cut at a line end
        // may still be a (smaller) valid mesh of their format, which only OBJ allows (it has no counts).
        let must_fail = name != "m.obj";
        for k in 0..50 {
            let cut = bytes.len() * k / 50;
            let p = d.write(&format!("cut{k}_{name}"), &bytes[..cut]);
            let r = std::panic::catch_unwind(|| load_mesh_file(&p))
                .unwrap_or_else(|_| panic!("{name} cut at {cut}: panic"));
            match r {
                Ok(m) => assert!(
                    !must_fail,
                    "{name} cut at {cut} bytes was accepted ({} faces)",
                    m.n_faces()
                ),
                Err(e) => {
                    let e = e.to_string();
                    assert!(
                        e.starts_with(&p.display().to_string()),
                        "{name} cut at {cut}: {e}"
                    );
                    assert!(!e.contains('\n'));
                }
            }
        }
    }
    // The external buffer of m.gltf cut short.
    let gltf = std::fs::read(fixture("m.gltf")).unwrap();
    let bin = std::fs::read(fixture("m.bin")).unwrap();
    d.write("m.gltf", &gltf);
    for k in 0..50 {
        d.write("m.bin", &bin[..bin.len() * k / 50]);
        refused(&d, "m.gltf", &gltf, &["buffer 0", "m.bin"]);
    }
}

// ---------------------------------------------------------------------------------------------------------
// gzjson compression bomb

/// A gzip stream of `n` spaces, built streaming (never `n` bytes in memory).
fn gzip_of_spaces(path: &Path, n: u64) {
    use flate2::{write::GzEncoder, Compression};
    use std::io::Write;
    let f = std::fs::File::create(path).unwrap();
    let mut e = GzEncoder::new(std::io::BufWriter::new(f), Compression::best());
    let block = vec![b' '; 1 << 20];
    let mut left = n;
    while left > 0 {
        let k = left.min(block.len() as u64) as usize;
        e.write_all(&block[..k]).unwrap();
        left -= k as u64;
    }
    e.finish().unwrap().flush().unwrap();
}

#[test]
fn a_gzjson_compression_bomb_is_refused_quickly_with_bounded_memory() {
    let d = Scratch::new("bomb");
    let bomb = d.0.join("bomb.gzjson");
    gzip_of_spaces(&bomb, 300 << 20);
    let compressed = std::fs::metadata(&bomb).unwrap().len();
    assert!(compressed < 1 << 20, "{compressed} bytes");
    let start = Instant::now();
    let err = gregvox::surface::beziex::load_beziex(&bomb)
        .unwrap_err()
        .to_string();
    let took = start.elapsed();
    let limit = gregvox::surface::beziex::inflate_limit(compressed);
    assert_eq!(limit, 64 << 20, "the floor applies to a small file");
    assert!(err.starts_with(&bomb.display().to_string()), "{err}");
    assert!(
        err.contains(&format!("inflates past {limit} bytes"))
            && err.contains("refusing a likely compression bomb"),
        "{err}"
    );
    assert!(took < Duration::from_secs(20), "took {took:?}");
    // The CLI on the bomb: one clear error, and its peak memory stays far below the 300 MB it inflates to.
    let out = Command::new("/bin/sh")
        .arg("-c")
        .arg(format!(
            "exec {} tessellate {} --out {}/t.obj",
            env!("CARGO_BIN_EXE_gregvox"),
            bomb.display(),
            d.0.display()
        ))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("refusing a likely compression bomb"),
        "{stderr}"
    );
    if let Some(kb) = peak_rss_kb(&bomb, &d) {
        eprintln!("gregvox tessellate on a {compressed}-byte bomb of 300 MiB: peak RSS {kb} kB");
        assert!(kb < 150 * 1024, "peak RSS {kb} kB");
    }
}

/// Peak RSS of `gregvox tessellate BOMB` in kB, where `/usr/bin/time` exists.
fn peak_rss_kb(bomb: &Path, d: &Scratch) -> Option<u64> {
    if !Path::new("/usr/bin/time").exists() {
        return None;
    }
    let out = Command::new("/usr/bin/time")
        .arg("-v")
        .arg(env!("CARGO_BIN_EXE_gregvox"))
        .arg("tessellate")
        .arg(bomb)
        .arg("--out")
        .arg(d.0.join("t.obj"))
        .output()
        .ok()?;
    let text = String::from_utf8_lossy(&out.stderr);
    text.lines()
        .find_map(|l| l.trim().strip_prefix("Maximum resident set size (kbytes):"))
        .and_then(|v| v.trim().parse().ok())
}

#[test]
fn gzjson_models_still_load_and_a_bom_inside_the_gzip_is_skipped() {
    use flate2::{write::GzEncoder, Compression};
    use std::io::Write;
    let d = Scratch::new("gz-ok");
    let real = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/models/beziex");
    let model = std::fs::read_dir(&real)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "gzjson"))
        .expect("a .gzjson model");
    let patches = gregvox::surface::beziex::load_beziex(&model).unwrap();
    assert!(!patches.is_empty());
    // The same JSON with a byte-order mark, gzipped.
    let mut text = String::new();
    use std::io::Read;
    flate2::read::GzDecoder::new(std::fs::File::open(&model).unwrap())
        .read_to_string(&mut text)
        .unwrap();
    let mut e = GzEncoder::new(Vec::new(), Compression::fast());
    e.write_all("\u{feff}".as_bytes()).unwrap();
    e.write_all(text.as_bytes()).unwrap();
    let p = d.write("bom.gzjson", &e.finish().unwrap());
    assert_eq!(gregvox::surface::beziex::load_beziex(&p).unwrap(), patches);
}
