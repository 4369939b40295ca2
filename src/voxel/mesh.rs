//! `TriMesh`: the triangle soup the voxelizers consume, its hygiene (exact duplicate and zero-area triangles
//! removed, with counts) and small procedural solids for tests.
//!
//! Invariants: positions are finite (checked by the constructors that take user data); every index is in
//! range. Hygiene compares vertex *positions* bit for bit, so unwelded duplicates are found too.
use crate::error::{Error, Result};

/// A triangle mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    pub positions: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

/// What [`TriMesh::clean`] removed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct CleanReport {
    /// Triangles dropped because another with the same three positions and the same orientation remained.
    pub duplicates: usize,
    /// Triangles dropped in pairs of the same three positions with opposite orientations (they cancel).
    pub cancelled: usize,
    /// Triangles with zero area.
    pub zero_area: usize,
}

impl TriMesh {
    /// The triangles of a loaded polygon mesh, each face fanned from its first vertex (the loader has
    /// validated indices and coordinates already), positions as f32.
    pub fn fan(mesh: &crate::mesh::Mesh) -> TriMesh {
        let positions = mesh
            .positions
            .iter()
            .map(|p| [p.x as f32, p.y as f32, p.z as f32])
            .collect();
        TriMesh {
            positions,
            triangles: mesh.fan_triangles(),
        }
    }

    /// A mesh from positions and polygon faces (fan-triangulated), with every index and coordinate checked.
    ///
    /// ```
    /// use gregvox::voxel::mesh::TriMesh;
    /// let quad = TriMesh::from_polygons(vec![[0.0; 3], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]], &[vec![0, 1, 2, 3]]).unwrap();
    /// assert_eq!(quad.triangles, [[0, 1, 2], [0, 2, 3]]);
    /// assert!(TriMesh::from_polygons(vec![[0.0; 3]], &[vec![0, 1, 2]]).is_err());
    /// ```
    pub fn from_polygons(positions: Vec<[f32; 3]>, faces: &[Vec<u32>]) -> Result<TriMesh> {
        for (i, p) in positions.iter().enumerate() {
            if p.iter().any(|c| !c.is_finite()) {
                return Err(Error::Invalid(format!(
                    "vertex {} has a NaN or infinite coordinate",
                    i + 1
                )));
            }
        }
        let mut triangles = Vec::with_capacity(faces.len() * 2);
        for (f, face) in faces.iter().enumerate() {
            if face.len() < 3 {
                return Err(Error::Invalid(format!(
                    "face {} has fewer than 3 vertices",
                    f + 1
                )));
            }
            if let Some(&bad) = face.iter().find(|&&v| v as usize >= positions.len()) {
                return Err(Error::Invalid(format!(
                    "face {} uses vertex {} but there are only {}",
                    f + 1,
                    bad as u64 + 1,
                    positions.len()
                )));
            }
            for k in 1..face.len() - 1 {
                triangles.push([face[0], face[k], face[k + 1]]);
            }
        }
        Ok(TriMesh {
            positions,
            triangles,
        })
    }

    /// Removes exact duplicate and zero-area triangles (see [`CleanReport`]).
    ///
    /// ```
    /// use gregvox::voxel::mesh::TriMesh;
    /// let mut m = TriMesh::cube([0.0; 3], 1.0);
    /// let n = m.triangles.len();
    /// m.triangles.extend_from_within(..);      // every face twice
    /// m.triangles.push([0, 0, 1]);             // zero area
    /// let (clean, report) = m.clean();
    /// assert_eq!((clean.triangles.len(), report.duplicates, report.zero_area), (n, n, 1));
    /// ```
    pub fn clean(&self) -> (TriMesh, CleanReport) {
        use rayon::prelude::*;
        let mut report = CleanReport::default();
        let key = |v: u32| self.positions[v as usize].map(f32::to_bits);
        // Each triangle's position triple in a canonical rotation (starting at the smallest position) with
        // its orientation (the order of the other two); sorted, equal triples sit together, by index.
        let mut keyed: Vec<([[u32; 3]; 3], u32, bool)> = self
            .triangles
            .par_iter()
            .enumerate()
            .filter(|(_, t)| !zero_area(self, **t))
            .map(|(i, t)| {
                let p = [key(t[0]), key(t[1]), key(t[2])];
                let r = (0..3).min_by_key(|&k| p[k]).unwrap();
                let (a, b, c) = (p[r], p[(r + 1) % 3], p[(r + 2) % 3]);
                if b < c {
                    ([a, b, c], i as u32, true)
                } else {
                    ([a, c, b], i as u32, false)
                }
            })
            .collect();
        report.zero_area = self.triangles.len() - keyed.len();
        keyed.par_sort_unstable_by(|x, y| (x.0, x.1).cmp(&(y.0, y.1)));
        let mut keep = Vec::new();
        for group in keyed.chunk_by(|x, y| x.0 == y.0) {
            // The first (lowest-index) triangle of each orientation.
            let f = group.iter().filter(|g| g.2).count();
            let b = group.len() - f;
            let pairs = f.min(b);
            report.cancelled += 2 * pairs;
            if f > b {
                keep.push(group.iter().find(|g| g.2).map_or(0, |g| g.1 as usize));
                report.duplicates += f - pairs - 1;
            } else if b > f {
                keep.push(group.iter().find(|g| !g.2).map_or(0, |g| g.1 as usize));
                report.duplicates += b - pairs - 1;
            }
        }
        keep.sort_unstable();
        let triangles = keep.into_iter().map(|i| self.triangles[i]).collect();
        (
            TriMesh {
                positions: self.positions.clone(),
                triangles,
            },
            report,
        )
    }

    /// An axis-aligned cube with outward-facing triangles, corner `min`, edge `size`.
    pub fn cube(min: [f32; 3], size: f32) -> TriMesh {
        let mut positions = Vec::new();
        for i in 0..8u32 {
            positions.push([
                min[0] + size * (i & 1) as f32,
                min[1] + size * (i >> 1 & 1) as f32,
                min[2] + size * (i >> 2 & 1) as f32,
            ]);
        }
        // Quads counter-clockwise seen from outside.
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let faces: Vec<Vec<u32>> = quads.iter().map(|q| q.to_vec()).collect();
        TriMesh::from_polygons(positions, &faces).expect("valid cube")
    }

    /// A UV sphere with outward-facing triangles (`inward` flips them: an inverted shell).
    pub fn sphere(
        centre: [f32; 3],
        radius: f32,
        rings: u32,
        segments: u32,
        inward: bool,
    ) -> TriMesh {
        let rings = rings.max(3);
        let segments = segments.max(3);
        let mut positions = vec![[centre[0], centre[1], centre[2] - radius]];
        for r in 1..rings {
            let theta = std::f64::consts::PI * r as f64 / rings as f64;
            for s in 0..segments {
                let phi = std::f64::consts::TAU * s as f64 / segments as f64;
                positions.push([
                    centre[0] + radius * (theta.sin() * phi.cos()) as f32,
                    centre[1] + radius * (theta.sin() * phi.sin()) as f32,
                    centre[2] - radius * theta.cos() as f32,
                ]);
            }
        }
        positions.push([centre[0], centre[1], centre[2] + radius]);
        let top = positions.len() as u32 - 1;
        let ring = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
        let mut triangles = Vec::new();
        for s in 0..segments {
            triangles.push([0, ring(1, s + 1), ring(1, s)]);
            triangles.push([top, ring(rings - 1, s), ring(rings - 1, s + 1)]);
        }
        for r in 1..rings - 1 {
            for s in 0..segments {
                let (a, b, c, d) = (
                    ring(r, s),
                    ring(r, s + 1),
                    ring(r + 1, s + 1),
                    ring(r + 1, s),
                );
                triangles.push([a, b, c]);
                triangles.push([a, c, d]);
            }
        }
        if inward {
            for t in &mut triangles {
                t.swap(1, 2);
            }
        }
        TriMesh {
            positions,
            triangles,
        }
    }

    /// A torus around the z axis with outward-facing triangles.
    pub fn torus(centre: [f32; 3], major: f32, minor: f32, rings: u32, segments: u32) -> TriMesh {
        let (rings, segments) = (rings.max(3), segments.max(3));
        let mut positions = Vec::new();
        for i in 0..rings {
            let a = std::f64::consts::TAU * i as f64 / rings as f64;
            for j in 0..segments {
                let b = std::f64::consts::TAU * j as f64 / segments as f64;
                let r = major as f64 + minor as f64 * b.cos();
                positions.push([
                    centre[0] + (r * a.cos()) as f32,
                    centre[1] + (r * a.sin()) as f32,
                    centre[2] + (minor as f64 * b.sin()) as f32,
                ]);
            }
        }
        let idx = |i: u32, j: u32| (i % rings) * segments + j % segments;
        let mut triangles = Vec::new();
        for i in 0..rings {
            for j in 0..segments {
                let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
                triangles.push([a, b, c]);
                triangles.push([a, c, d]);
            }
        }
        TriMesh {
            positions,
            triangles,
        }
    }

    /// Appends `other`'s triangles (a union of shells, overlapping or not).
    pub fn append(&mut self, other: &TriMesh) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.triangles
            .extend(other.triangles.iter().map(|t| t.map(|v| v + base)));
    }
}

fn zero_area(mesh: &TriMesh, t: [u32; 3]) -> bool {
    let p = t.map(|v| mesh.positions[v as usize].map(|c| c as f64));
    let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
    let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
    let n = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    n == [0.0, 0.0, 0.0]
}
