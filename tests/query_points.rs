//! Specification of the point queries (`api::query`): at uniform points in the padded box and at points
//! near the surface, the winding number equals the plain sum of the solid angles (the exact formula
//! libigl's `winding_number` evaluates) within 1e-6, occupancy equals |w| ≥ ½ of that sum wherever it is
//! not within 1e-6 of ½, and distances equal the brute-force minimum over every triangle; on the bunny
//! with its five holes, the bunny with a third of its triangles removed (thousands of holes), an unwelded
//! noisy soup and a closed sphere (integer winding numbers). Points on the surface and bad input are
//! defined too. At scale, against libigl itself: 10⁶ uniform and 10⁶ near-surface points of the bunny, the
//! bunny with 5 % of its triangles removed and the soup, drawn as `tests/oracle/gen_query.py` draws them
//! (fixtures in `tests/fixtures/query/`): occupancy at every point, winding numbers at every 500th.
mod common;

use common::{dataset_points, model};
use gregvox::api::query::{MeshQuery, QueryOptions, SdfSign};
use gregvox::api::Mesh;
use gregvox::mesh::load_mesh_file;
use gregvox::voxel::gwn::kernel::{triangle_distance, winding_sum};
use gregvox::voxel::gwn::Inside;
use gregvox::voxel::mesh::TriMesh;
use gregvox::voxel::stress::{fnv1a, obj_text, polygon_prism, soup, suite, with_holes};
use std::io::Read;

fn mesh_of(t: &TriMesh) -> Mesh {
    gregvox::mesh::parse_obj(&obj_text(t), "case.obj").unwrap()
}

fn triangles(t: &TriMesh) -> Vec<[[f64; 3]; 3]> {
    t.triangles
        .iter()
        .map(|f| f.map(|v| t.positions[v as usize].map(f64::from)))
        .collect()
}

fn check_case(name: &str, t: &TriMesh, n: usize) {
    let mesh = mesh_of(t);
    let q = MeshQuery::new(&mesh, &QueryOptions::default()).unwrap();
    let pts = dataset_points(t, n, 7);
    let (w, occ) = q.winding_and_occupancy(&pts).unwrap();
    // The reference: the plain sum over the cleaned triangles (the same hygiene; these meshes have no
    // duplicates, so it is every triangle).
    let (clean, _) = t.clean();
    let tris = triangles(&clean);
    let all = triangles(t);
    // The occupancy call decides by octree cells of points (shared bounds), not point by point: the same
    // answers.
    let shared = q.occupancy(&pts).unwrap();
    let d = q.unsigned_distance(&pts).unwrap();
    let s = q.signed_distance(&pts).unwrap();
    let mut worst = 0.0f64;
    let mut near_half = 0;
    let diag = {
        let (lo, hi) = all.iter().flatten().fold(
            ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
            |(lo, hi), p| {
                (
                    std::array::from_fn(|a| lo[a].min(p[a])),
                    std::array::from_fn(|a| hi[a].max(p[a])),
                )
            },
        );
        (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt()
    };
    for (i, p) in pts.iter().enumerate() {
        let r = winding_sum(&tris, *p);
        worst = worst.max((w[i] - r).abs());
        assert!(
            (w[i] - r).abs() <= 1e-6,
            "{name} point {i} {p:?}: {} vs {r}",
            w[i]
        );
        if (r.abs() - 0.5).abs() > 1e-6 {
            assert_eq!(occ[i], r.abs() >= 0.5, "{name} point {i}: w = {r}");
            assert_eq!(shared[i], occ[i], "{name} point {i}: w = {r}");
        } else {
            near_half += 1;
        }
        let bd = all
            .iter()
            .map(|t| triangle_distance(*p, t[0], t[1], t[2]))
            .fold(f64::INFINITY, f64::min);
        assert!(
            (d.distance[i] as f64 - bd).abs() <= 1e-6 * diag,
            "{name} point {i}: distance {} vs {bd}",
            d.distance[i]
        );
        // The closest point lies on its face at the distance given.
        let c = d.closest[i];
        let cd = (0..3).map(|a| (c[a] - p[a]).powi(2)).sum::<f64>().sqrt();
        assert!((cd - bd).abs() <= 1e-6 * diag, "{name} point {i}");
        let f = all[d.face[i] as usize];
        let b = d.barycentric[i];
        let on: [f64; 3] =
            std::array::from_fn(|a| b[0] * f[0][a] + b[1] * f[1][a] + b[2] * f[2][a]);
        assert!(
            (0..3).all(|a| (on[a] - c[a]).abs() <= 1e-9 * diag),
            "{name} point {i}"
        );
        // Signed: negative inside.
        assert_eq!(s.distance[i].abs(), d.distance[i]);
        if d.distance[i] > 0.0 {
            assert_eq!(s.distance[i] < 0.0, occ[i], "{name} point {i}");
        }
    }
    eprintln!(
        "{name}: {} points, worst |w − plain sum| {worst:.2e}, {near_half} within 1e-6 of ½, {} inside",
        pts.len(),
        occ.iter().filter(|&&o| o).count()
    );
}

/// FNV-1a of the first and last 10,000 points' float64 bytes (little-endian): what the fixture records.
fn points_digest(points: &[[f64; 3]]) -> String {
    let ends = points[..10_000]
        .iter()
        .chain(&points[points.len() - 10_000..]);
    let bytes: Vec<u8> = ends.flatten().flat_map(|x| x.to_le_bytes()).collect();
    format!("{:016x}", fnv1a(&bytes))
}

fn bunny() -> TriMesh {
    TriMesh::fan(&load_mesh_file(model("stanford-bunny.obj")).unwrap())
}

#[test]
fn the_open_bunny_matches_the_plain_sum_and_brute_force_distances() {
    check_case("bunny", &bunny(), 300);
}

/// One search (`nearest_triangles`) gives the rows of the separate calls: unsigned, and signed by the
/// points' occupancy.
#[test]
fn one_nearest_triangle_search_gives_the_signed_and_unsigned_rows() {
    let t = with_holes(&bunny(), 0.05, 9);
    let q = MeshQuery::new(&mesh_of(&t), &QueryOptions::default()).unwrap();
    let pts = dataset_points(&t, 2000, 5);
    let nearest = q.nearest_triangles(&pts, None).unwrap();
    let occupancy = q.occupancy(&pts).unwrap();
    for (rows, call) in [
        (
            q.distance_rows(&nearest, None).unwrap(),
            q.unsigned_distance(&pts).unwrap(),
        ),
        (
            q.distance_rows(&nearest, Some(&occupancy)).unwrap(),
            q.signed_distance(&pts).unwrap(),
        ),
    ] {
        assert_eq!(rows.face, call.face);
        assert_eq!(rows.closest, call.closest);
        assert_eq!(rows.barycentric, call.barycentric);
        let bits = |d: &[f32]| d.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&rows.distance), bits(&call.distance));
    }
    assert!(nearest.faces.len() == pts.len() && nearest.check.checked == 0);
    // An occupancy of another length is refused, not a panic.
    assert!(q.distance_rows(&nearest, Some(&occupancy[1..])).is_err());
}

#[test]
fn thousands_of_holes_and_an_unwelded_soup_match_the_plain_sum() {
    let b = bunny();
    check_case("bunny_holes_third", &with_holes(&b, 1.0 / 3.0, 3), 200);
    check_case("bunny_soup", &soup(&b, 1e-7, 5), 200);
}

#[test]
fn a_prism_with_huge_polygon_caps_matches_the_plain_sum() {
    // Two 4,000-gons fanned from one vertex: 3,998 long slivers per cap meeting at a point, the attack on
    // the crossing index's buckets (every cell crossed by slivers) and on the distance tree's boxes. Open
    // on one side panel: the fractional term is a cap across it.
    let prism = polygon_prism(4000);
    check_case("prism_4000_gon_caps", &prism, 150);
}

#[test]
fn a_closed_mesh_gives_integer_winding_numbers() {
    let sphere = TriMesh::sphere([0.1, 0.2, 0.3], 1.0, 24, 48, false);
    check_case("sphere", &sphere, 500);
    let q = MeshQuery::new(&mesh_of(&sphere), &QueryOptions::default()).unwrap();
    let w = q
        .winding_numbers(&[[0.1, 0.2, 0.3], [3.0, 0.0, 0.0]])
        .unwrap();
    assert_eq!(w, [1.0, 0.0]);
}

#[test]
fn the_sign_conventions_and_the_positive_rule() {
    let sphere = TriMesh::sphere([0.0; 3], 1.0, 16, 32, false);
    // Inward orientation: w = −1 inside.
    let mut inward = sphere.clone();
    for t in &mut inward.triangles {
        t.swap(1, 2);
    }
    let centre = [[0.0; 3]];
    let q = MeshQuery::new(&mesh_of(&inward), &QueryOptions::default()).unwrap();
    assert_eq!(q.winding_numbers(&centre).unwrap(), [-1.0]);
    assert_eq!(q.occupancy(&centre).unwrap(), [true]);
    assert!(q.signed_distance(&centre).unwrap().distance[0] < 0.0);
    let positive = QueryOptions {
        inside: Inside::Positive,
        sdf_sign: SdfSign::InsidePositive,
        ..QueryOptions::default()
    };
    let q = MeshQuery::new(&mesh_of(&inward), &positive).unwrap();
    assert_eq!(q.occupancy(&centre).unwrap(), [false]);
    let q = MeshQuery::new(&mesh_of(&sphere), &positive).unwrap();
    assert!(q.signed_distance(&centre).unwrap().distance[0] > 0.0);
}

#[test]
fn points_on_the_surface_get_the_plain_sum_and_distance_zero() {
    let cube = TriMesh::cube([0.0; 3], 1.0);
    let q = MeshQuery::new(&mesh_of(&cube), &QueryOptions::default()).unwrap();
    let tris = triangles(&cube);
    // On a face (one the crossing ray runs parallel to, and one it crosses), on an edge, on a vertex.
    let on = [
        [0.5, 0.0, 0.25],
        [0.25, 0.5, 1.0],
        [0.5, 0.0, 0.0],
        [1.0, 1.0, 1.0],
    ];
    let w = q.winding_numbers(&on).unwrap();
    for (p, w) in on.iter().zip(&w) {
        assert_eq!(*w, winding_sum(&tris, *p), "{p:?}");
    }
    let d = q.signed_distance(&on).unwrap();
    assert!(d.distance.iter().all(|&x| x == 0.0), "{:?}", d.distance);
}

#[test]
fn bad_points_and_empty_meshes_are_refused_with_one_message() {
    let cube = TriMesh::cube([0.0; 3], 1.0);
    let q = MeshQuery::new(&mesh_of(&cube), &QueryOptions::default()).unwrap();
    let e = q
        .winding_numbers(&[[0.0; 3], [f64::NAN, 0.0, 0.0]])
        .unwrap_err()
        .to_string();
    assert!(e.contains("point 1") && e.contains("not finite"), "{e}");
    let flat =
        gregvox::mesh::parse_obj("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", "flat.obj").unwrap();
    let e = MeshQuery::new(&flat, &QueryOptions::default())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("no triangle"), "{e}");
    // Prepared for unsigned distances only: the same distances, and a clear error for the rest.
    let d = MeshQuery::distances_only(&mesh_of(&cube), &QueryOptions::default()).unwrap();
    let p = [[0.5, 0.5, 2.0], [0.25, 0.5, 0.5]];
    assert_eq!(
        d.unsigned_distance(&p).unwrap().distance,
        q.unsigned_distance(&p).unwrap().distance
    );
    let e = d.occupancy(&p).unwrap_err().to_string();
    assert!(e.contains("distances only"), "{e}");
    assert!(d.signed_distance(&p).is_err());
    let bad = QueryOptions {
        tolerance: 0.0,
        ..QueryOptions::default()
    };
    assert!(MeshQuery::new(&mesh_of(&cube), &bad).is_err());
}

/// The oracle of `tests/oracle/gen_query.py`: at 10⁶ uniform and 10⁶ near-surface points of the bunny (five
/// holes), the bunny with 5 % of its triangles removed (about 3,000 holes) and the unwelded noisy soup,
/// occupancy equals |w| ≥ ½ of libigl's exact winding number at every point whose exact |w| is not within 1e-6
/// of ½, and the winding numbers at every 500th point equal libigl's within 1e-6.
#[test]
fn a_million_uniform_and_a_million_near_points_per_mesh_match_libigls_exact_winding_number() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/query");
    let index: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("index.json")).unwrap()).unwrap();
    let n = index["points"].as_u64().unwrap() as usize;
    let seed = index["seed"].as_u64().unwrap();
    let stride = index["stride"].as_u64().unwrap() as usize;
    let b = bunny();
    let teapot = TriMesh::fan(&load_mesh_file(model("teapot.obj")).unwrap());
    let cases = suite(&b, &teapot);
    for case in index["cases"].as_array().unwrap() {
        let name = case["model"].as_str().unwrap();
        let t = if name == "stanford-bunny" {
            let bytes = std::fs::read(model("stanford-bunny.obj")).unwrap();
            assert_eq!(
                format!("{:016x}", fnv1a(&bytes)),
                case["fnv1a"].as_str().unwrap()
            );
            b.clone()
        } else {
            let t = cases.iter().find(|c| c.name == name).unwrap().mesh.clone();
            assert_eq!(
                format!("{:016x}", fnv1a(obj_text(&t).as_bytes())),
                case["fnv1a"].as_str().unwrap(),
                "{name}: the generator no longer makes the mesh the oracle saw (rerun gen_query.py)"
            );
            t
        };
        let points = dataset_points(&t, n, seed);
        assert_eq!(
            points_digest(&points),
            case["points_fnv1a"].as_str().unwrap(),
            "{name}: the points differ from the oracle's"
        );
        let mut blob = Vec::new();
        flate2::read::ZlibDecoder::new(
            std::fs::File::open(dir.join(case["file"].as_str().unwrap())).unwrap(),
        )
        .read_to_end(&mut blob)
        .unwrap();
        let (bits, values) = blob.split_at((2 * n).div_ceil(8));
        let want_w: Vec<f64> = values
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(want_w.len(), (2 * n).div_ceil(stride));
        let near_half: Vec<usize> = case["near_half"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap() as usize)
            .collect();
        let q = MeshQuery::new(&mesh_of(&t), &QueryOptions::default()).unwrap();
        let occ = q.occupancy(&points).unwrap();
        let mut wrong = Vec::new();
        for (i, &o) in occ.iter().enumerate() {
            let want = bits[i / 8] >> (i % 8) & 1 == 1;
            if o != want && near_half.binary_search(&i).is_err() {
                wrong.push(i);
            }
        }
        assert!(
            wrong.is_empty(),
            "{name}: {} of {} points differ from libigl's exact occupancy (first {:?})",
            wrong.len(),
            occ.len(),
            &wrong[..wrong.len().min(5)]
        );
        let inside = occ.iter().filter(|&&o| o).count();
        let want_inside =
            case["inside_uniform"].as_u64().unwrap() + case["inside_near"].as_u64().unwrap();
        assert!(
            (inside as u64).abs_diff(want_inside) <= near_half.len() as u64,
            "{name}: {inside} inside, the oracle {want_inside}"
        );
        let strided: Vec<[f64; 3]> = points.iter().step_by(stride).copied().collect();
        let w = q.winding_numbers(&strided).unwrap();
        let worst = w
            .iter()
            .zip(&want_w)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f64, f64::max);
        assert!(
            worst <= 1e-6,
            "{name}: winding numbers {worst:.2e} from libigl's exact ones"
        );
        eprintln!(
            "{name}: {} points, {inside} inside, {} within 1e-6 of ½, winding numbers at {} points within {worst:.1e}",
            points.len(),
            near_half.len(),
            strided.len()
        );
    }
}
