//! Vertex normals as B·N_f against libigl (AREA, its default) and trimesh (ANGLE), and the zero-normal
//! policy for unreferenced and degenerate vertices.
mod mesh_common;
use glam::DVec3;
use gregvox::mesh::{
    face_centroids, face_normals, load_obj, parse_obj, vertex_normals, MeshMatrix, NormalWeighting,
};
use mesh_common::{model, read_f64x3};

/// Max component difference over referenced vertices; unreferenced vertices must be exactly zero here
/// (libigl gives them NaN, which the fixture keeps).
fn compare(name: &str, fixture: &str, weighting: NormalWeighting) -> f64 {
    let mesh = load_obj(model(name)).unwrap();
    let m = MeshMatrix::from_mesh(&mesh);
    let ours = m.vertex_normals(&mesh.positions, weighting);
    let oracle = read_f64x3(fixture);
    assert_eq!(
        ours.len(),
        oracle.len(),
        "{name}: one normal per vertex, unreferenced included"
    );
    let mut worst = 0.0f64;
    let mut compared = 0;
    for v in 0..ours.len() {
        assert!(ours[v].is_finite(), "{name}: vertex {v} normal not finite");
        if m.is_referenced(v) {
            worst = worst.max((ours[v] - oracle[v]).abs().max_element());
            compared += 1;
        } else {
            assert_eq!(
                ours[v],
                DVec3::ZERO,
                "{name}: unreferenced vertex {v} gets a zero normal"
            );
        }
    }
    eprintln!("{name} {weighting:?}: {compared} vertices, max component difference {worst:e}");
    worst
}

// Tolerance 1e-12 from the issue; measured differences are a few ulps (libigl sums area·unit normals,
// we sum unnormalised normals: equal up to rounding).
#[test]
fn area_normals_equal_libigl_on_the_bunny_referenced_vertices() {
    assert!(
        compare(
            "stanford-bunny.obj",
            "stanford-bunny.normals_area.f64",
            NormalWeighting::Area
        ) <= 1e-12
    );
}

#[test]
fn area_normals_equal_libigl_on_spot() {
    assert!(compare("spot.obj", "spot.normals_area.f64", NormalWeighting::Area) <= 1e-12);
}

#[test]
fn area_normals_equal_libigl_on_cow() {
    assert!(compare("cow.obj", "cow.normals_area.f64", NormalWeighting::Area) <= 1e-12);
}

#[test]
fn angle_normals_equal_trimesh_vertex_normals_on_spot() {
    assert!(
        compare(
            "spot.obj",
            "spot.normals_angle_trimesh.f64",
            NormalWeighting::Angle
        ) <= 1e-12
    );
}

#[test]
fn weightings_differ_where_they_should() {
    // trimesh's default (ANGLE) is not libigl's default (AREA): the notes measure up to 1.15 on the bunny
    let mesh = load_obj(model("spot.obj")).unwrap();
    let m = MeshMatrix::from_mesh(&mesh);
    let area = m.vertex_normals(&mesh.positions, NormalWeighting::Area);
    let angle = m.vertex_normals(&mesh.positions, NormalWeighting::Angle);
    let uniform = m.vertex_normals(&mesh.positions, NormalWeighting::Uniform);
    let d = |a: &[DVec3], b: &[DVec3]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (*x - *y).length())
            .fold(0.0, f64::max)
    };
    assert!(d(&area, &angle) > 1e-3 && d(&area, &uniform) > 1e-3);
}

#[test]
fn uniform_normals_of_a_square_pyramid_apex_point_up() {
    let text =
        "v 0 0 1\nv 1 0 0\nv 0 1 0\nv -1 0 0\nv 0 -1 0\nf 1 2 3\nf 1 3 4\nf 1 4 5\nf 1 5 2\n";
    let mesh = parse_obj(text, "pyramid.obj").unwrap();
    let m = MeshMatrix::from_mesh(&mesh);
    for w in [
        NormalWeighting::Area,
        NormalWeighting::Uniform,
        NormalWeighting::Angle,
    ] {
        let n = vertex_normals(&m, &mesh.positions, w);
        assert!((n[0] - DVec3::Z).length() < 1e-15, "{w:?}: {}", n[0]);
    }
}

#[test]
fn degenerate_faces_give_zero_not_nan() {
    // all three vertices on a line: zero face normal, zero vertex normals, no NaN
    let mesh = parse_obj("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", "line.obj").unwrap();
    let m = MeshMatrix::from_mesh(&mesh);
    assert_eq!(face_normals(&m, &mesh.positions), vec![DVec3::ZERO]);
    for w in [
        NormalWeighting::Area,
        NormalWeighting::Uniform,
        NormalWeighting::Angle,
    ] {
        assert!(m
            .vertex_normals(&mesh.positions, w)
            .iter()
            .all(|n| *n == DVec3::ZERO));
    }
}

#[test]
fn polygon_normals_and_centroids() {
    // a planar pentagon in z = 2: normal +Z, centroid = vertex average
    let text = "v 0 0 2\nv 2 0 2\nv 3 1 2\nv 1 3 2\nv -1 1 2\nf 1 2 3 4 5\n";
    let mesh = parse_obj(text, "penta.obj").unwrap();
    let m = MeshMatrix::from_mesh(&mesh);
    assert_eq!(face_normals(&m, &mesh.positions), vec![DVec3::Z]);
    assert_eq!(
        face_centroids(&m, &mesh.positions),
        vec![DVec3::new(1.0, 1.0, 2.0)]
    );
    assert!(m
        .vertex_normals(&mesh.positions, NormalWeighting::Area)
        .iter()
        .all(|n| *n == DVec3::Z));
}

#[test]
fn f32_gpu_twin_is_within_2e_5_of_libigl_on_bunny_spot_cow() {
    // notes A.4: f32 emulation vs libigl AREA measured 6.7e-6 (bunny), 3.4e-6 (spot), 3.1e-6 (cow);
    // tolerance 2e-5 per component as for the GPU path
    for (name, fixture) in [
        ("stanford-bunny.obj", "stanford-bunny.normals_area.f64"),
        ("spot.obj", "spot.normals_area.f64"),
        ("cow.obj", "cow.normals_area.f64"),
    ] {
        let mesh = load_obj(model(name)).unwrap();
        let m = MeshMatrix::from_mesh(&mesh);
        let p32: Vec<[f32; 3]> = mesh
            .positions
            .iter()
            .map(|p| p.as_vec3().to_array())
            .collect();
        let n = gregvox::mesh::vertex_normals_f32(&m, &p32);
        let oracle = read_f64x3(fixture);
        let mut worst = 0.0f64;
        for v in 0..n.len() {
            if m.is_referenced(v) {
                let d = DVec3::new(n[v][0] as f64, n[v][1] as f64, n[v][2] as f64) - oracle[v];
                worst = worst.max(d.abs().max_element());
            } else {
                assert_eq!(n[v], [0.0; 3]);
            }
        }
        eprintln!("{name} f32: max component difference {worst:e}");
        assert!(worst <= 2e-5, "{name}: {worst}");
    }
}
