//! Suite `query`: point queries (`api::query`) against libigl at the same points, in the same run:
//! occupancy and winding numbers against `igl.fast_winding_number` (approximate), signed distance against
//! `igl.signed_distance` with its fast-winding-number sign, unsigned distance against
//! `igl.point_mesh_squared_distance`; on the bunny (five holes), the bunny with a third of its triangles
//! removed (thousands of holes), the unwelded noisy soup, a closed model and a prism whose caps are two
//! 4,000-gons (7,996 slivers meeting at two points, one side panel open: the attack on the crossing index,
//! the distance tree and the caps).
//!
//! Invariants: the points are uniform in the box padded by 10 % and near the surface (area-weighted
//! samples moved by normal offsets of σ = 1 % of the box's longest side), seeded, written once as float64
//! `.npy` for the peer; every gregvox time is one whole call as a user makes it, preparation included
//! (`MeshQuery::new` + the query), median of the repeats; libigl's calls build their own trees inside
//! (`bench/peers/query_peers.py`, all cores).
use super::peers::{self, Peer};
use super::{median, num, speedup, BenchConfig, Report, Table};
use crate::api::query::{MeshQuery, QueryOptions, SampleSpec};
use crate::api::Mesh;
use crate::mesh::load_mesh_file;
use crate::voxel::mesh::TriMesh;
use crate::voxel::stress::{obj_text, polygon_prism, soup, with_holes};
use serde_json::Value;
use std::time::Instant;

/// Points the winding-value column is timed on.
const WINDING_POINTS: usize = 2_000;

fn time<T>(repeats: usize, mut f: impl FnMut() -> T) -> f64 {
    let mut times = Vec::new();
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        std::hint::black_box(f());
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    median(&times)
}

/// Runs the suite.
pub fn run(cfg: &BenchConfig, report: &mut Report) -> anyhow::Result<()> {
    let n = if cfg.quick { 10_000 } else { 100_000 };
    let repeats = if cfg.quick { 1 } else { 3 };
    let bunny = TriMesh::fan(&load_mesh_file(cfg.model("stanford-bunny.obj")?)?);
    let cases: Vec<(&str, TriMesh)> = vec![
        ("stanford-bunny (5 holes)", bunny.clone()),
        ("bunny_holes_third", with_holes(&bunny, 1.0 / 3.0, 3)),
        ("bunny_soup", soup(&bunny, 1e-7, 5)),
        (
            "spot (closed)",
            TriMesh::fan(&load_mesh_file(cfg.model("spot.obj")?)?),
        ),
        // The worst case for the crossing index and the distance tree: 2 × 3,998 slivers meeting at a
        // point, and a cap across the open panel.
        (
            "prism of two 4,000-gons, one panel open",
            polygon_prism(4000),
        ),
    ];
    let dir = std::env::temp_dir().join(format!("gregvox-bench-query-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    // The device path beside the CPU's (lavapipe on a machine without a GPU); the suite runs without one.
    let gpu = match crate::api::Gpu::new() {
        Ok(g) => Some(g),
        Err(e) => {
            eprintln!("gregvox bench: query: no Vulkan device for the device column ({e})");
            None
        }
    };
    let device_name = gpu
        .as_ref()
        .map_or("none".to_string(), |g| g.context().info.name.clone());
    let mut t = Table::new(
        "query",
        "Point queries vs libigl at the same points (whole calls, preparation included)",
        &format!(
            "{n} points per row: uniform in the box padded by 10 %, or near the surface (σ = 1 % of the box). \
             gregvox: prepare = MeshQuery::new (weld, caps, trees, crossing index); occupancy = the \
             query on the prepared mesh, decided by bounds (exact); occupancy speed-up = libigl fwn / \
             (prepare + occupancy); winding = values within 1e-6, per point, timed on the first 2,000 \
             points; sdf and udf = whole calls (prepare, the distance tree and the query); medians of \
             {repeats} on all {} rayon threads. libigl = fast_winding_number \
             (approximate), signed_distance with its fast-winding-number sign, \
             point_mesh_squared_distance, its own threading (bench/peers/query_peers.py). speed-up = \
             libigl / gregvox. occupancy vs fwn = points where |w| ≥ ½ differs from libigl's w ≥ ½ \
             (the rules differ only on inward parts; the fast winding number's error near ½ does the \
             rest). udf device = the udf call with the nearest pieces searched on the Vulkan device \
             ({device_name}; MeshQuery::unsigned_distance_on: the pipeline, the tree's upload, the search \
             in f64 and the host's check of every answer, which makes the rows the CPU's); device check \
             = searches the host corrected / finished (0 / 0: the device's answers were the CPU's).",
            rayon::current_num_threads()
        ),
        &[
            "mesh",
            "triangles",
            "points",
            "prepare ms",
            "occupancy ms",
            "libigl fwn ms",
            "occupancy speed-up",
            "winding µs/point",
            "libigl fwn µs/point",
            "sdf ms",
            "libigl sdf ms",
            "sdf speed-up",
            "udf ms",
            "libigl udf ms",
            "udf speed-up",
            "udf device ms",
            "device check",
            "occupancy vs fwn",
        ],
    );
    for (name, tri) in &cases {
        let mesh: Mesh = crate::mesh::parse_obj(&obj_text(tri), "case.obj")?;
        let obj = dir.join("case.obj");
        std::fs::write(&obj, obj_text(tri))?;
        let opts = QueryOptions::default();
        let prepared = MeshQuery::new(&mesh, &opts)?;
        let box_side = {
            let (lo, hi) = tri.positions.iter().fold(
                ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
                |(lo, hi), p| {
                    (
                        std::array::from_fn(|a| lo[a].min(p[a])),
                        std::array::from_fn(|a| hi[a].max(p[a])),
                    )
                },
            );
            (0..3).map(|a| (hi[a] - lo[a]) as f64).fold(0.0, f64::max)
        };
        for (kind, spec) in [
            ("uniform", SampleSpec::Uniform(n)),
            (
                "near",
                SampleSpec::Near {
                    sigma: 0.01 * box_side,
                    n,
                },
            ),
        ] {
            let points = prepared.sample(&[spec], 0.1, 11)?.points;
            let p_path = dir.join("points.npy");
            let flat: Vec<f64> = points.iter().flatten().copied().collect();
            let mut arr = crate::npy::Array::f64s(&flat);
            arr.shape = vec![points.len(), 3];
            std::fs::write(&p_path, arr.npy())?;
            let prep_ms = time(repeats, || MeshQuery::new(&mesh, &opts).map(|_| 0));
            let occ_ms = time(repeats, || prepared.occupancy(&points).map(|v| v.len()));
            // Winding values within 1e-6 cost far more than decisions near many caps: timed on the first
            // WINDING_POINTS points, per point.
            let few = &points[..points.len().min(WINDING_POINTS)];
            let wind_us =
                time(1, || prepared.winding_numbers(few).map(|v| v.len())) * 1e3 / few.len() as f64;
            let sdf_ms = time(repeats, || {
                MeshQuery::new(&mesh, &opts)
                    .and_then(|q| q.signed_distance(&points))
                    .map(|v| v.distance.len())
            });
            let udf_ms = time(repeats, || {
                MeshQuery::distances_only(&mesh, &opts)
                    .and_then(|q| q.unsigned_distance(&points))
                    .map(|v| v.distance.len())
            });
            let mut check = None;
            let device_ms = gpu.as_ref().map(|g| {
                time(repeats, || {
                    MeshQuery::distances_only(&mesh, &opts)
                        .and_then(|q| q.unsigned_distance_on(g, &points))
                        .map(|(v, c)| {
                            check = Some(c);
                            v.distance.len()
                        })
                })
            });
            let occ = prepared.occupancy(&points)?;
            let inside = occ.iter().filter(|&&o| o).count() as i64;
            let peer = peers::python(
                &cfg.repo.join("bench/peers/query_peers.py"),
                &[
                    obj.display().to_string(),
                    p_path.display().to_string(),
                    repeats.to_string(),
                ],
            );
            let get = |key: &str| -> Option<f64> {
                match &peer {
                    Peer::Ran(v) => v.first().and_then(|o| o[key].as_f64()),
                    _ => None,
                }
            };
            let (fwn, sdf, udf) = (
                get("fwn_s").map(|s| s * 1e3),
                get("sdf_s").map(|s| s * 1e3),
                get("udf_s").map(|s| s * 1e3),
            );
            let cell = |v: Option<f64>| match v {
                Some(x) => num(x),
                None => Value::from(peer.status()),
            };
            t.push(vec![
                Value::from(format!("{name}, {kind}")),
                Value::from(tri.triangles.len()),
                Value::from(points.len()),
                num(prep_ms),
                num(occ_ms),
                cell(fwn),
                speedup(fwn, prep_ms + occ_ms),
                num(wind_us),
                match fwn {
                    Some(f) => num(f * 1e3 / points.len() as f64),
                    None => Value::from("–"),
                },
                num(sdf_ms),
                cell(sdf),
                speedup(sdf, sdf_ms),
                num(udf_ms),
                cell(udf),
                speedup(udf, udf_ms),
                device_ms.map_or(Value::from("no device"), num),
                check.map_or(Value::from("–"), |c| {
                    Value::from(format!("{} / {}", c.corrected, c.incomplete))
                }),
                match get("fwn_inside") {
                    Some(k) => Value::from((k as i64 - inside).abs()),
                    None => Value::from("–"),
                },
            ]);
            eprintln!(
                "gregvox bench: query {name} {kind}: prepare {prep_ms:.1} ms, occupancy {occ_ms:.1} ms, \
                 winding {wind_us:.1} µs/point, sdf {sdf_ms:.1} ms, udf {udf_ms:.1} ms, udf device \
                 {device_ms:?} ms ({check:?}); libigl fwn {fwn:?} sdf {sdf:?} udf {udf:?}"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    report.tables.push(t);
    Ok(())
}
