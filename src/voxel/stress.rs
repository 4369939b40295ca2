//! The generalized winding number's stress suite: seeded broken meshes of the kinds real datasets are full
//! of, beside the models they come from. The tests compare each against libigl's exact winding number
//! (fixtures from `tests/oracle/gen_gwn_stress.py`, which reads the OBJ files `cargo run --example
//! gwn_stress` writes); `gregvox bench --suite gwn` times each as a whole `gregvox voxelize` process.
//!
//! Every case is a pure function of its inputs and a fixed seed (SplitMix64; the same bits on every
//! platform): [`obj_text`] of a case and its FNV-1a hash ([`fnv1a`]) are what the fixtures record, so a
//! changed generator is caught before a stale oracle is trusted.
//!
//! The cases ([`suite`]):
//! - `bunny_holes_5pct`, `bunny_holes_third`: the Stanford bunny with 5 % and a third of its triangles
//!   removed at random (about 2,800 and 4,300 boundary loops): thousands of small caps.
//! - `bunny_soup`: the bunny as an unwelded soup, every triangle its own three vertices, each coordinate moved
//!   by uniform noise of ±1e-7 (model units; the bunny is 0.16 across): no two copies of a vertex meet.
//! - `open_shells`: 300 overlapping open spherical shells (random centres, radii, axes and openings): cups
//!   and bowls, each with a large cap across its opening.
//! - `chair`: a ShapeNet-style chair: a seat and four legs that are boxes open at the bottom, a one-sided
//!   back panel, the seat's top duplicated, one leg inside out.
//! - `teapot`: the Utah teapot as shipped (a real open model).
//!
//! The bunny itself (five holes) is the suite's baseline, and the soup's welded twin.
//!
//! Outside the suite, [`open_tube`] attacks the caps themselves: two loops of any number of edges (the
//! bench's `gwn_worst` table uses half a million each; `tests/voxel_gwn.rs` checks 10⁵ against the plain sum).
use super::mesh::TriMesh;
use std::fmt::Write as _;

pub use crate::geom::random::SplitMix64;

/// One case of the suite.
#[derive(Clone, Debug)]
pub struct StressCase {
    pub name: &'static str,
    /// What makes it hard.
    pub what: &'static str,
    pub mesh: TriMesh,
}

/// `mesh` with `fraction` of its triangles removed (chosen by a seeded shuffle; the rest keep their order).
pub fn with_holes(mesh: &TriMesh, fraction: f64, seed: u64) -> TriMesh {
    let n = mesh.triangles.len();
    let mut order: Vec<usize> = (0..n).collect();
    let mut rng = SplitMix64(seed);
    for i in (1..n).rev() {
        order.swap(i, rng.below(i + 1));
    }
    let removed = ((n as f64) * fraction).floor() as usize;
    let mut keep = vec![true; n];
    for &i in &order[..removed] {
        keep[i] = false;
    }
    TriMesh {
        positions: mesh.positions.clone(),
        triangles: mesh
            .triangles
            .iter()
            .zip(&keep)
            .filter(|(_, &k)| k)
            .map(|(t, _)| *t)
            .collect(),
    }
}

/// `mesh` as an unwelded soup: every triangle its own three vertices, each coordinate moved by uniform
/// noise in [−noise, noise] (in f64, then rounded to f32).
pub fn soup(mesh: &TriMesh, noise: f64, seed: u64) -> TriMesh {
    let mut rng = SplitMix64(seed);
    let mut out = TriMesh::default();
    for t in &mesh.triangles {
        let n = out.positions.len() as u32;
        for &v in t {
            let p = mesh.positions[v as usize];
            out.positions
                .push(p.map(|x| (x as f64 + noise * (2.0 * rng.unit() - 1.0)) as f32));
        }
        out.triangles.push([n, n + 1, n + 2]);
    }
    out
}

/// An open tube: a cylinder of radius ½ and height 1 round z, `segments` quads (two triangles each) round,
/// outward, both ends open: two boundary loops of `segments` edges each, whose caps are one polygon of
/// `segments` sides apiece. The attack on the caps (a loop of a million edges) and on the voxels near them
/// (w is ½ on the end planes, so every voxel near either end disc must be decided one by one).
pub fn open_tube(segments: usize) -> TriMesh {
    let n = segments.max(3);
    let mut out = TriMesh::default();
    for z in [-0.5f64, 0.5] {
        for i in 0..n {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            out.positions
                .push([(0.5 * a.cos()) as f32, (0.5 * a.sin()) as f32, z as f32]);
        }
    }
    let n32 = n as u32;
    for i in 0..n32 {
        let j = (i + 1) % n32;
        out.triangles.push([i, j, n32 + j]);
        out.triangles.push([i, n32 + j, n32 + i]);
    }
    out
}

/// A prism over a regular `n`-gon (unit circumradius, height 1), its two caps one polygon each (fanned from
/// one vertex into n − 2 long slivers meeting at a point) and its side panels quads, one panel left out: an
/// open mesh whose fractional term is a cap across that panel. The attack on the crossing index's buckets
/// (every cell crossed by slivers), on the distance tree's boxes and on the queries near the caps
/// (`tests/query_points.rs`, the query bench).
pub fn polygon_prism(n: u32) -> TriMesh {
    let n = n.max(3);
    let mut positions = Vec::new();
    for z in [0.0f32, 1.0] {
        for i in 0..n {
            let t = std::f32::consts::TAU * i as f32 / n as f32;
            positions.push([t.cos(), t.sin(), z]);
        }
    }
    let mut faces: Vec<Vec<u32>> = vec![(0..n).rev().collect(), (n..2 * n).collect()];
    for i in 1..n {
        faces.push(vec![i - 1, i, n + i, n + i - 1]);
    }
    TriMesh::from_polygons(positions, &faces).expect("a prism's polygons are valid")
}

/// `count` overlapping open spherical shells in the unit cube: each a zone of a sphere from its pole down to
/// a random polar angle (54° to 126°), at a random centre, radius (0.015 to 0.05) and axis, outward,
/// `rings`×`segments` quads.
pub fn open_shells(count: usize, rings: u32, segments: u32, seed: u64) -> TriMesh {
    let mut rng = SplitMix64(seed);
    let mut out = TriMesh::default();
    for _ in 0..count {
        let centre = [
            0.15 + 0.7 * rng.unit(),
            0.15 + 0.7 * rng.unit(),
            0.15 + 0.7 * rng.unit(),
        ];
        let radius = 0.015 + 0.035 * rng.unit();
        let opening = std::f64::consts::PI * (0.3 + 0.4 * rng.unit());
        // A uniform axis and two vectors across it.
        let z = 2.0 * rng.unit() - 1.0;
        let phi = std::f64::consts::TAU * rng.unit();
        let s = (1.0 - z * z).sqrt();
        let axis = [s * phi.cos(), s * phi.sin(), z];
        let helper = if axis[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let u = normalize(cross(axis, helper));
        let v = cross(axis, u);
        let base = out.positions.len() as u32;
        let pole = out.positions.len() as u32;
        out.positions.push(std::array::from_fn(|k| {
            (centre[k] + radius * axis[k]) as f32
        }));
        for r in 1..=rings {
            let theta = opening * r as f64 / rings as f64;
            for j in 0..segments {
                let a = std::f64::consts::TAU * j as f64 / segments as f64;
                let (st, ct) = theta.sin_cos();
                let dir: [f64; 3] =
                    std::array::from_fn(|k| ct * axis[k] + st * (a.cos() * u[k] + a.sin() * v[k]));
                out.positions.push(std::array::from_fn(|k| {
                    (centre[k] + radius * dir[k]) as f32
                }));
            }
        }
        let at = |r: u32, j: u32| base + 1 + (r - 1) * segments + j % segments;
        for j in 0..segments {
            out.triangles.push([pole, at(1, j), at(1, j + 1)]);
        }
        for r in 1..rings {
            for j in 0..segments {
                out.triangles
                    .push([at(r, j), at(r + 1, j), at(r + 1, j + 1)]);
                out.triangles
                    .push([at(r, j), at(r + 1, j + 1), at(r, j + 1)]);
            }
        }
    }
    out
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    a.map(|x| x / n)
}

/// A grid of `k`×`k` quads (two triangles each) from corner `o` along edges `a` and `b` (normal a × b).
fn panel(out: &mut TriMesh, o: [f64; 3], a: [f64; 3], b: [f64; 3], k: u32) {
    let base = out.positions.len() as u32;
    for i in 0..=k {
        for j in 0..=k {
            let (s, t) = (i as f64 / k as f64, j as f64 / k as f64);
            out.positions
                .push(std::array::from_fn(|c| (o[c] + s * a[c] + t * b[c]) as f32));
        }
    }
    let at = |i: u32, j: u32| base + i * (k + 1) + j;
    for i in 0..k {
        for j in 0..k {
            out.triangles
                .push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            out.triangles
                .push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
}

/// An axis-aligned box from `lo` to `hi`, outward, without its bottom (−y) face, `k`×`k` quads a face.
fn open_box(out: &mut TriMesh, lo: [f64; 3], hi: [f64; 3], k: u32) {
    let d = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let (x, y, z) = ([d[0], 0.0, 0.0], [0.0, d[1], 0.0], [0.0, 0.0, d[2]]);
    panel(out, [lo[0], hi[1], lo[2]], z, x, k); // +y: z × x
    panel(out, lo, z, y, k); // −x: z × y
    panel(out, [hi[0], lo[1], lo[2]], y, z, k); // +x: y × z
    panel(out, lo, y, x, k); // −z: y × x
    panel(out, [lo[0], lo[1], hi[2]], x, y, k); // +z: x × y
}

/// The chair (see the module docs). Coordinates are offset by irrational-looking amounts so no face lies
/// on a plane of voxel centres of a cubic grid over its box.
pub fn chair() -> TriMesh {
    let mut out = TriMesh::default();
    let k = 6;
    // The seat: a box open at the bottom.
    open_box(
        &mut out,
        [0.1013, 0.4517, 0.1029],
        [0.9041, 0.5533, 0.9017],
        k,
    );
    // The seat's top, duplicated (an exact copy of its triangles).
    let top: Vec<[u32; 3]> = out.triangles[..2 * (k * k) as usize].to_vec();
    out.triangles.extend(top);
    // Four legs, open at the bottom; the last one inside out.
    let legs = [
        ([0.1171, 0.0113, 0.1187], [0.1977, 0.4517, 0.1993]),
        ([0.8083, 0.0113, 0.1187], [0.8889, 0.4517, 0.1993]),
        ([0.1171, 0.0113, 0.8067], [0.1977, 0.4517, 0.8873]),
        ([0.8083, 0.0113, 0.8067], [0.8889, 0.4517, 0.8873]),
    ];
    for (n, (lo, hi)) in legs.iter().enumerate() {
        let first = out.triangles.len();
        open_box(&mut out, *lo, *hi, 3);
        if n == 3 {
            for t in &mut out.triangles[first..] {
                t.swap(1, 2);
            }
        }
    }
    // The back: one quad grid, no thickness, facing the seat.
    panel(
        &mut out,
        [0.1013, 0.5533, 0.8689],
        [0.8028, 0.0, 0.0],
        [0.0, 0.6311, 0.0],
        8,
    );
    out
}

/// The whole suite from the bunny and the teapot (as loaded: positions and triangles).
pub fn suite(bunny: &TriMesh, teapot: &TriMesh) -> Vec<StressCase> {
    vec![
        StressCase {
            name: "bunny_holes_5pct",
            what: "the bunny, 5 % of its triangles removed at random: thousands of small holes",
            mesh: with_holes(bunny, 0.05, 20261204),
        },
        StressCase {
            name: "bunny_holes_third",
            what: "the bunny, a third of its triangles removed at random: holes everywhere",
            mesh: with_holes(bunny, 1.0 / 3.0, 20261205),
        },
        StressCase {
            name: "bunny_soup",
            what: "the bunny as an unwelded soup with ±1e-7 noise on every vertex",
            mesh: soup(bunny, 1e-7, 20261206),
        },
        StressCase {
            name: "open_shells",
            what: "300 overlapping open spherical shells",
            mesh: open_shells(300, 6, 16, 20261207),
        },
        StressCase {
            name: "chair",
            what: "open-bottom boxes, a one-sided panel, duplicated faces, an inverted leg",
            mesh: chair(),
        },
        StressCase {
            name: "teapot",
            what: "the Utah teapot as shipped: a real open model",
            mesh: teapot.clone(),
        },
    ]
}

/// The OBJ text of `mesh` (positions as Rust's shortest round-trip f32 text, 1-based faces): what the
/// fixtures hash.
pub fn obj_text(mesh: &TriMesh) -> String {
    let mut s = String::with_capacity(mesh.positions.len() * 40 + mesh.triangles.len() * 24);
    s.push_str("# a gregvox stress case (src/voxel/stress.rs)\n");
    for p in &mesh.positions {
        let _ = writeln!(s, "v {} {} {}", p[0], p[1], p[2]);
    }
    for t in &mesh.triangles {
        let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s
}

/// FNV-1a (64 bits) of `bytes`.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_generators_are_seeded_and_the_chair_is_what_it_says() {
        let shells = open_shells(3, 4, 8, 1);
        assert_eq!(shells.triangles.len(), 3 * (8 + 3 * 8 * 2));
        assert_eq!(
            fnv1a(obj_text(&shells).as_bytes()),
            fnv1a(obj_text(&open_shells(3, 4, 8, 1)).as_bytes())
        );
        assert_ne!(obj_text(&shells), obj_text(&open_shells(3, 4, 8, 2)));
        let chair = chair();
        let (clean, removed) = chair.clean();
        assert_eq!(removed.duplicates, 72, "the seat's top, once");
        // Open: the bottoms of five boxes and the rim of the panel.
        let p = crate::voxel::gwn::Proxy::new(&clean, 0.0).unwrap();
        assert_eq!(p.cap.loops.len(), 6, "{:?}", p.cap.loops.len());
        let cube = TriMesh::cube([0.0; 3], 1.0);
        let holed = with_holes(&cube, 0.5, 3);
        assert_eq!(holed.triangles.len(), 6);
        let s = soup(&cube, 1e-3, 4);
        assert_eq!((s.positions.len(), s.triangles.len()), (36, 12));
        // A closed box with its bottom gone is capped once, and inside it the winding number is one.
        let mut b = TriMesh::default();
        open_box(&mut b, [0.0; 3], [1.0; 3], 2);
        let w = crate::voxel::gwn::winding_number(&b, [0.5, 0.9, 0.5]);
        assert!(w > 0.5 && w < 1.0, "{w}");
    }
}
