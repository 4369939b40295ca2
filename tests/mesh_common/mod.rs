//! Helpers shared by the `mesh_*` integration tests: model and fixture paths, fixture readers, and
//! nearest-point matching for comparing vertex sets whose order differs.
#![allow(dead_code)]
use glam::DVec3;
use std::collections::HashMap;
use std::path::PathBuf;

/// `assets/models/NAME` of the repository.
pub fn model(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("assets/models")
        .join(name)
}

/// `tests/fixtures/mesh/NAME`.
pub fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/mesh")
        .join(name)
}

/// Rows of 3 little-endian f64.
pub fn read_f64x3(name: &str) -> Vec<DVec3> {
    let b = std::fs::read(fixture(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    b.chunks_exact(24)
        .map(|c| {
            let f = |i: usize| f64::from_le_bytes(c[8 * i..8 * i + 8].try_into().unwrap());
            DVec3::new(f(0), f(1), f(2))
        })
        .collect()
}

/// Flat little-endian u32.
pub fn read_u32(name: &str) -> Vec<u32> {
    let b = std::fs::read(fixture(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    b.chunks_exact(4)
        .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

/// The oracle summary (`summary.json`).
pub fn summary() -> serde_json::Value {
    let t = std::fs::read_to_string(fixture("summary.json")).expect("summary.json");
    serde_json::from_str(&t).expect("summary.json parses")
}

/// For every point of `a`, the index of the nearest point of `b` and the distance (grid hash with
/// cell `cell`; points farther than one cell are reported as unmatched with distance infinity).
pub fn nearest(a: &[DVec3], b: &[DVec3], cell: f64) -> Vec<(usize, f64)> {
    let key = |p: DVec3| -> [i64; 3] {
        [
            (p.x / cell).floor() as i64,
            (p.y / cell).floor() as i64,
            (p.z / cell).floor() as i64,
        ]
    };
    let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for (i, &p) in b.iter().enumerate() {
        grid.entry(key(p)).or_default().push(i);
    }
    a.iter()
        .map(|&p| {
            let k = key(p);
            let mut best = (usize::MAX, f64::INFINITY);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        if let Some(l) = grid.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) {
                            for &i in l {
                                let d = (b[i] - p).length();
                                if d < best.1 {
                                    best = (i, d);
                                }
                            }
                        }
                    }
                }
            }
            best
        })
        .collect()
}

/// Rotates a polygon so its smallest vertex id comes first (orientation kept).
pub fn canonical_face(f: &[u32]) -> Vec<u32> {
    let k = (0..f.len()).min_by_key(|&i| f[i]).unwrap();
    (0..f.len()).map(|i| f[(k + i) % f.len()]).collect()
}
