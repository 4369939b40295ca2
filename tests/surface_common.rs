//! Shared helpers of the `surface_*` tests (included with `#[path]`; as its own target it has no tests).
//!
//! Fixture format: see tests/oracle/osd_gregory.cpp (OpenSubdiv 3.5, Far isolation 0, GREGORY_BASIS).
#![allow(dead_code)]
use glam::DVec3;
use gregvox::geom::gregory::PatchF64;
use gregvox::mesh::{Mesh, MeshMatrix, NONE};
use std::collections::HashMap;

pub fn model(rel: &str) -> String {
    format!("{}/assets/models/{rel}", env!("CARGO_MANIFEST_DIR"))
}

pub fn fixture_path(name: &str) -> String {
    format!(
        "{}/tests/fixtures/surface/{name}.osd",
        env!("CARGO_MANIFEST_DIR")
    )
}

/// One OpenSubdiv fixture: the cage it saw and per patch (= face) its 20 points.
pub struct Fixture {
    pub cage: Vec<DVec3>,
    pub faces: Vec<Vec<u32>>,
    /// 0 = REGULAR (converted to Bézier), 1 = GREGORY_BASIS, 2 = a hole (no patch), 3 = GREGORY_BASIS whose
    /// face points OpenSubdiv 3.5 computed with a non-affine row (compare P, Ep, Em only).
    pub types: Vec<u32>,
    pub points: Vec<[DVec3; 20]>,
    /// Per patch: (u, v, P, Du, Dv) as 11 doubles.
    pub samples: Vec<Vec<[f64; 11]>>,
    /// Points were stored as f32.
    pub f32_points: bool,
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}
impl Reader<'_> {
    fn u32(&mut self) -> u32 {
        let v = u32::from_le_bytes(self.b[self.at..self.at + 4].try_into().unwrap());
        self.at += 4;
        v
    }
    fn f64(&mut self) -> f64 {
        let v = f64::from_le_bytes(self.b[self.at..self.at + 8].try_into().unwrap());
        self.at += 8;
        v
    }
    fn f32(&mut self) -> f64 {
        let v = f32::from_le_bytes(self.b[self.at..self.at + 4].try_into().unwrap());
        self.at += 4;
        v as f64
    }
}

pub fn read_fixture(name: &str) -> Fixture {
    let bytes = std::fs::read(fixture_path(name))
        .expect("fixture (regenerate with tests/oracle/build_osd.sh)");
    assert_eq!(&bytes[..8], b"GVOSD001");
    let mut r = Reader { b: &bytes, at: 8 };
    let (nv, nf, pb, ns) = (
        r.u32() as usize,
        r.u32() as usize,
        r.u32(),
        r.u32() as usize,
    );
    let cage = (0..nv)
        .map(|_| DVec3::new(r.f64(), r.f64(), r.f64()))
        .collect();
    let ptr: Vec<u32> = (0..=nf).map(|_| r.u32()).collect();
    let idx: Vec<u32> = (0..ptr[nf]).map(|_| r.u32()).collect();
    let faces = (0..nf)
        .map(|f| idx[ptr[f] as usize..ptr[f + 1] as usize].to_vec())
        .collect();
    let types = (0..nf).map(|_| r.u32()).collect();
    let mut points = Vec::with_capacity(nf);
    for _ in 0..nf {
        let mut p = [DVec3::ZERO; 20];
        for q in p.iter_mut() {
            *q = if pb == 4 {
                DVec3::new(r.f32(), r.f32(), r.f32())
            } else {
                DVec3::new(r.f64(), r.f64(), r.f64())
            };
        }
        points.push(p);
    }
    let samples = (0..nf)
        .map(|_| (0..ns).map(|_| std::array::from_fn(|_| r.f64())).collect())
        .collect();
    assert_eq!(r.at, bytes.len(), "fixture {name}: trailing bytes");
    Fixture {
        cage,
        faces,
        types,
        points,
        samples,
        f32_points: pb == 4,
    }
}

pub fn diag(p: &[DVec3]) -> f64 {
    let lo = p.iter().fold(DVec3::splat(f64::INFINITY), |a, &b| a.min(b));
    let hi = p
        .iter()
        .fold(DVec3::splat(f64::NEG_INFINITY), |a, &b| a.max(b));
    (hi - lo).length()
}

pub fn angle(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// (u, v) of the point at fraction s along the edge from corner `slot` to corner `slot + 1`.
pub fn edge_uv(slot: usize, s: f64) -> (f64, f64) {
    match slot {
        0 => (s, 0.0),
        1 => (1.0, s),
        2 => (1.0 - s, 1.0),
        _ => (0.0, 1.0 - s),
    }
}

/// Twin corner of every corner of an all-quad mesh (face-major corners), or NONE.
pub fn twin_corners(m: &MeshMatrix) -> Vec<u32> {
    let cv = m.corner_vertex();
    (0..m.n_corners())
        .map(|c| {
            let (a, b) = (cv[c], cv[m.next(c as u32) as usize]);
            let k = m.find(b, a);
            if k == NONE {
                NONE
            } else {
                let f = m.half_edge_face().face1[k as usize] - 1;
                let s = m.face_start(f as usize);
                (s..s + 4).find(|&cc| cv[cc as usize] == b).unwrap()
            }
        })
        .collect()
}

/// G1 figures over every interior edge, `n` samples per edge.
#[derive(Debug, Default)]
pub struct G1 {
    /// Max position gap (absolute).
    pub gap: f64,
    /// Max normal jump (rad).
    pub jump: f64,
    /// Interior edges checked.
    pub edges: usize,
    /// Corner samples skipped because S_u ∥ S_v there (interior valence-2 vertices: OpenSubdiv's σ_2 = 0
    /// puts Ep = Em = P; the exact mask gives Em − P = −(Ep − P)): the normal is undefined and each patch
    /// falls back to its own.
    pub skipped: usize,
}

/// Edges used by exactly two faces, counted from the face lists alone (not from the mesh matrices the G1
/// measure pairs corners with), so that a measure which found no shared edge cannot pass.
pub fn interior_edges(mesh: &Mesh) -> usize {
    let mut uses: HashMap<(u32, u32), usize> = HashMap::new();
    for f in 0..mesh.n_faces() {
        let face = mesh.face(f);
        for k in 0..face.len() {
            let (a, b) = (face[k], face[(k + 1) % face.len()]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    uses.values().filter(|&&n| n == 2).count()
}

/// G1 figures over every interior edge at `n` samples each; fails unless it checked exactly the
/// [`interior_edges`] of `mesh` (and at least one).
pub fn g1_figures(mesh: &Mesh, patches: &[PatchF64], n: usize) -> G1 {
    let r = g1_figures_unchecked(mesh, patches, n);
    let expected = interior_edges(mesh);
    assert!(expected > 0, "the cage has no interior edge to check");
    assert_eq!(
        r.edges, expected,
        "G1 checked {} of {expected} interior edges",
        r.edges
    );
    r
}

fn g1_figures_unchecked(mesh: &Mesh, patches: &[PatchF64], n: usize) -> G1 {
    let m = MeshMatrix::from_mesh(mesh);
    let twin = twin_corners(&m);
    let mut r = G1::default();
    for (c, &t) in twin.iter().enumerate() {
        if t == NONE || (t as usize) < c {
            continue;
        }
        r.edges += 1;
        let (f, i) = (c / 4, c % 4);
        let (g, k) = (t as usize / 4, t as usize % 4);
        for q in 0..n {
            let s = q as f64 / (n - 1) as f64;
            let (u1, v1) = edge_uv(i, s);
            let (u2, v2) = edge_uv(k, 1.0 - s);
            let (p1, su, sv) = patches[f].eval(u1, v1);
            let p2 = patches[g].eval(u2, v2).0;
            r.gap = r.gap.max((p1 - p2).length());
            // a corner where S_u ∥ S_v (or both 0) has no tangent plane: each patch uses its fallback
            if (q == 0 || q == n - 1) && su.cross(sv).length() <= 1e-10 * su.length() * sv.length()
            {
                r.skipped += 1;
                continue;
            }
            let a = angle(patches[f].normal(u1, v1), patches[g].normal(u2, v2));
            r.jump = r.jump.max(a);
        }
    }
    r
}

/// A tiny deterministic generator (xorshift64*), uniform in [-1, 1).
pub struct Rng(pub u64);
impl Rng {
    pub fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let x = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D);
        (x >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
    /// A random vector of length ≤ r.
    pub fn ball(&mut self, r: f64) -> DVec3 {
        loop {
            let v = DVec3::new(self.uniform(), self.uniform(), self.uniform());
            if v.length() <= 1.0 {
                return v * r;
            }
        }
    }
}

/// The worst distance between OpenSubdiv's patches and ours matched one to one by geometry (numberings
/// differ after a refinement), up to a rotation of the corners (a cyclic shift of the 5-point corner
/// blocks); panics if two of theirs match the same one of ours.
pub fn worst_matched_patch(
    name: &str,
    ours: &[gregvox::geom::gregory::PatchF64],
    theirs: &[&[DVec3; 20]],
) -> f64 {
    let mut used = vec![false; ours.len()];
    let mut worst = 0.0f64;
    for t in theirs {
        let mut best = (f64::INFINITY, 0);
        for (g, p) in ours.iter().enumerate() {
            for r in 0..4 {
                let e = (0..20)
                    .map(|j| (p.cv[(j + 5 * r) % 20] - t[j]).length())
                    .fold(0.0, f64::max);
                if e < best.0 {
                    best = (e, g);
                }
            }
        }
        assert!(
            !used[best.1],
            "{name}: two OpenSubdiv patches matched gregvox patch {}",
            best.1
        );
        used[best.1] = true;
        worst = worst.max(best.0);
    }
    worst
}

/// The f64 records of fixture `tests/fixtures/surface/{name}.{ext}` (u32 count, then count × `width`
/// little-endian f64: the oracle's --ptex and --fvar files).
/// `GREGVOX_SURFACE_FIXTURES=DIR` reads them from DIR instead (a longer run: the oracle with a larger N,
/// see tests/oracle/build_osd.sh).
pub fn read_records(name: &str, ext: &str, width: usize) -> Vec<Vec<f64>> {
    let dir = std::env::var("GREGVOX_SURFACE_FIXTURES")
        .unwrap_or_else(|_| format!("{}/tests/fixtures/surface", env!("CARGO_MANIFEST_DIR")));
    let path = format!("{dir}/{name}.{ext}");
    let b = std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let n = u32::from_le_bytes(b[..4].try_into().unwrap()) as usize;
    let f: Vec<f64> = b[4..]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect();
    assert_eq!(f.len(), width * n, "{path}");
    f.chunks_exact(width).map(|r| r.to_vec()).collect()
}

/// Writes rows as an (N, 3) float64 .npy.
pub fn write_npy_f64(path: &std::path::Path, rows: &[[f64; 3]]) {
    let mut header = format!(
        "{{'descr': '<f8', 'fortran_order': False, 'shape': ({}, 3), }}",
        rows.len()
    );
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut b = b"\x93NUMPY\x01\x00".to_vec();
    b.extend_from_slice(&(header.len() as u16).to_le_bytes());
    b.extend_from_slice(header.as_bytes());
    for r in rows {
        for x in r {
            b.extend_from_slice(&x.to_le_bytes());
        }
    }
    std::fs::write(path, b).unwrap();
}

/// The float64 data of entry `name` of a stored (uncompressed) .npz.
pub fn npz_f64(z: &[u8], name: &str) -> Option<Vec<f64>> {
    let key = format!("{name}.npy");
    // The name as a whole: "uv.npy" also ends "duv.npy".
    let at = (1..z.len().saturating_sub(key.len()))
        .find(|&i| &z[i..i + key.len()] == key.as_bytes() && !z[i - 1].is_ascii_alphanumeric())?;
    let magic = at + z[at..].windows(6).position(|w| w == b"\x93NUMPY")?;
    let hlen = u16::from_le_bytes([z[magic + 8], z[magic + 9]]) as usize;
    let header = std::str::from_utf8(&z[magic + 10..magic + 10 + hlen]).ok()?;
    let shape = &header[header.find("'shape': (")? + 10..];
    let dims: Vec<usize> = shape[..shape.find(')')?]
        .split(',')
        .filter_map(|s| s.trim().parse().ok())
        .collect();
    let n: usize = dims.iter().product();
    let data = magic + 10 + hlen;
    Some(
        (0..n)
            .map(|k| f64::from_le_bytes(z[data + 8 * k..data + 8 * k + 8].try_into().unwrap()))
            .collect(),
    )
}

/// An n × n grid of unit quads in the z = 0 plane as OBJ text (vertex (i, j) is 1-based j·(n + 1) + i + 1).
pub fn grid_obj(n: usize) -> String {
    let mut text = String::new();
    for j in 0..=n {
        for i in 0..=n {
            text += &format!("v {i} {j} 0\n");
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i + 1;
            text += &format!("f {a} {} {} {}\n", a + 1, a + n + 2, a + n + 1);
        }
    }
    text
}
