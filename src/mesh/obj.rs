//! OBJ reading and writing, and explicit welding.
//!
//! Invariants of a loaded [`Mesh`]: positions are exactly the file's `v` lines in file order, as `f64`
//! (no welding, no reordering, unreferenced vertices kept); faces are the file's `f` lines in file order,
//! polygons kept (never triangulated), indices 0-based; every face has ≥ 3 distinct in-range vertices and
//! every coordinate is finite. Anything else is an [`Error::Parse`] naming the file and the line.
//!
//! Why not `tobj` here: tobj 4 re-indexes every object's vertices in first-use order, drops unreferenced
//! vertices and reads `f32` unless the crate-wide `use_f64` feature is on. Each of those breaks the
//! loading contract (positions as given, f64 normals equal to libigl's to 1e-12), so this module reads
//! the few OBJ statements a mesh needs (`v`, `f`) itself, with line numbers for every error, and skips
//! everything else (`vt`, `vn`, `o`, `g`, `s`, `usemtl`, `mtllib`, `l`, `p`, …).
use crate::error::{Error, Result};
use glam::DVec3;
use std::collections::HashMap;
use std::path::Path;

/// A polygon mesh as read from a file: positions and faces as offsets into one index array.
///
/// ```
/// let m = gregvox::mesh::parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "t.obj").unwrap();
/// assert_eq!((m.face_ptr.clone(), m.indices.clone()), (vec![0, 3], vec![0, 1, 2]));
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    /// Vertex positions, in file order.
    pub positions: Vec<DVec3>,
    /// Face offsets into `indices`: face `f` is `indices[face_ptr[f]..face_ptr[f + 1]]` (|F| + 1 entries).
    pub face_ptr: Vec<u32>,
    /// 0-based vertex indices of all faces, concatenated, in winding order.
    pub indices: Vec<u32>,
}

impl Mesh {
    /// Builds a mesh from positions and a list of polygons (validating like the loader does).
    ///
    /// ```
    /// use gregvox::mesh::Mesh;
    /// use glam::DVec3;
    /// let m = Mesh::from_polygons(vec![DVec3::ZERO, DVec3::X, DVec3::Y], &[vec![0, 1, 2]]).unwrap();
    /// assert_eq!(m.n_faces(), 1);
    /// assert!(Mesh::from_polygons(vec![DVec3::ZERO], &[vec![0, 1, 2]]).is_err());
    /// ```
    pub fn from_polygons(positions: Vec<DVec3>, faces: &[Vec<u32>]) -> Result<Self> {
        let mut face_ptr = vec![0u32];
        let mut indices = Vec::new();
        for f in faces {
            indices.extend_from_slice(f);
            face_ptr.push(indices.len() as u32);
        }
        Mesh::from_offsets(positions, face_ptr, indices)
    }

    /// Builds a mesh from positions, face offsets (|F| + 1, starting at 0) and the concatenated indices,
    /// validating like the loader does; no per-face allocation (the Python bindings pass arrays so).
    ///
    /// ```
    /// use gregvox::mesh::Mesh;
    /// use glam::DVec3;
    /// let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::ONE];
    /// let m = Mesh::from_offsets(p.clone(), vec![0, 3, 6], vec![0, 1, 2, 2, 1, 3]).unwrap();
    /// assert_eq!(m.face(1), &[2, 1, 3]);
    /// assert!(Mesh::from_offsets(p.clone(), vec![0, 3, 5], vec![0, 1, 2, 2, 1, 3]).is_err());
    /// assert!(Mesh::from_offsets(p, vec![0, 3], vec![0, 1, 4]).is_err());
    /// ```
    pub fn from_offsets(
        positions: Vec<DVec3>,
        face_ptr: Vec<u32>,
        indices: Vec<u32>,
    ) -> Result<Self> {
        if face_ptr.first() != Some(&0)
            || face_ptr.last().map(|&n| n as usize) != Some(indices.len())
            || face_ptr.windows(2).any(|w| w[1] < w[0])
        {
            return Err(Error::Mesh(format!(
                "the face offsets do not cover the {} indices in order (from 0, never decreasing)",
                indices.len()
            )));
        }
        let mesh = Mesh {
            positions,
            face_ptr,
            indices,
        };
        mesh.validate()?;
        Ok(mesh)
    }

    /// Number of faces.
    ///
    /// ```
    /// # use gregvox::mesh::Mesh; use glam::DVec3;
    /// let m = Mesh::from_polygons(vec![DVec3::ZERO, DVec3::X, DVec3::Y], &[vec![0, 1, 2]]).unwrap();
    /// assert_eq!(m.n_faces(), 1);
    /// ```
    pub fn n_faces(&self) -> usize {
        self.face_ptr.len() - 1
    }

    /// The vertex indices of face `f`.
    ///
    /// ```
    /// # use gregvox::mesh::Mesh; use glam::DVec3;
    /// let m = Mesh::from_polygons(vec![DVec3::ZERO, DVec3::X, DVec3::Y], &[vec![2, 0, 1]]).unwrap();
    /// assert_eq!(m.face(0), &[2, 0, 1]);
    /// ```
    pub fn face(&self, f: usize) -> &[u32] {
        &self.indices[self.face_ptr[f] as usize..self.face_ptr[f + 1] as usize]
    }

    /// Fan triangulation (`[v0, vk, vk+1]` per polygon, in face order); triangles are kept as they are.
    /// Loading keeps polygons; this is the "unless asked" of the loading contract. A fan diagonal may
    /// coincide with an existing edge (suzanne has one) and then makes it non-manifold: analyse polygon
    /// meshes as polygons.
    ///
    /// ```
    /// # use gregvox::mesh::Mesh; use glam::DVec3;
    /// let p = vec![DVec3::ZERO, DVec3::X, DVec3::ONE, DVec3::Y];
    /// let t = Mesh::from_polygons(p, &[vec![0, 1, 2, 3]]).unwrap().triangulated();
    /// assert_eq!((t.face(0), t.face(1)), (&[0, 1, 2][..], &[0, 2, 3][..]));
    /// ```
    pub fn triangulated(&self) -> Mesh {
        Mesh::of_triangles(self.positions.clone(), &self.fan_triangles())
    }

    /// A triangle mesh from indices the caller has already checked (in range, three distinct corners
    /// or not: no validation here).
    pub(crate) fn of_triangles(positions: Vec<DVec3>, tri: &[[u32; 3]]) -> Mesh {
        Mesh {
            positions,
            face_ptr: (0..=tri.len() as u32).map(|k| 3 * k).collect(),
            indices: tri.iter().flatten().copied().collect(),
        }
    }

    /// Every face fanned from its first corner, as index triples (faces of fewer than 3 corners give
    /// none).
    ///
    /// ```
    /// # use gregvox::mesh::Mesh; use glam::DVec3;
    /// let p = vec![DVec3::ZERO, DVec3::X, DVec3::ONE, DVec3::Y];
    /// let m = Mesh::from_polygons(p, &[vec![0, 1, 2, 3]]).unwrap();
    /// assert_eq!(m.fan_triangles(), [[0, 1, 2], [0, 2, 3]]);
    /// ```
    pub fn fan_triangles(&self) -> Vec<[u32; 3]> {
        let mut t = Vec::with_capacity(self.indices.len());
        for f in 0..self.n_faces() {
            let face = self.face(f);
            for k in 1..face.len().saturating_sub(1) {
                t.push([face[0], face[k], face[k + 1]]);
            }
        }
        t
    }

    /// Checks the invariants (no file, so errors name face and vertex indices).
    fn validate(&self) -> Result<()> {
        if self.positions.is_empty() {
            return Err(Error::Invalid("mesh has no vertices".into()));
        }
        if self.n_faces() == 0 {
            return Err(Error::Invalid("mesh has no faces".into()));
        }
        for (i, p) in self.positions.iter().enumerate() {
            if !p.is_finite() {
                return Err(Error::Invalid(format!(
                    "vertex {i} has a non-finite coordinate {p}"
                )));
            }
        }
        for f in 0..self.n_faces() {
            let face = self.face(f);
            if let Some(msg) = check_face(face, self.positions.len(), 1) {
                return Err(Error::Invalid(format!("face {f}: {msg}")));
            }
        }
        Ok(())
    }
}

/// Checks one face (0-based indices): size, range, repeated vertices. Messages number vertices from
/// `base` (1 for OBJ and in-memory meshes, 0 for formats whose files count from 0).
pub(crate) fn check_face(face: &[u32], n_verts: usize, base: u64) -> Option<String> {
    if face.len() < 3 {
        return Some(format!(
            "has {} vertices (a face needs at least 3)",
            face.len()
        ));
    }
    for &v in face {
        if v as usize >= n_verts {
            return Some(format!(
                "vertex index {} is out of range (there are {n_verts} vertices{})",
                v as u64 + base,
                if base == 0 { ", numbered from 0" } else { "" }
            ));
        }
    }
    first_repeated(face).map(|v| format!("vertex {} appears twice in one face", v as u64 + base))
}

/// A vertex that appears more than once in `face`, if any. A quadratic scan for ordinary faces (no
/// allocation); sorting for long ones, where the scan would take hours (a million-vertex face is 5·10¹¹
/// comparisons).
pub(crate) fn first_repeated(face: &[u32]) -> Option<u32> {
    if face.len() <= 32 {
        face.iter()
            .enumerate()
            .find(|&(a, v)| face[..a].contains(v))
            .map(|(_, &v)| v)
    } else {
        let mut sorted = face.to_vec();
        sorted.sort_unstable();
        sorted.windows(2).find(|w| w[0] == w[1]).map(|w| w[0])
    }
}

/// Reads an OBJ file (see the module invariants).
///
/// ```
/// let dir = std::env::temp_dir().join("gregvox-doc-load-obj");
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("tri.obj");
/// std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 5 5\nf 1 2 3\n").unwrap();
/// let mesh = gregvox::mesh::load_obj(&path).unwrap();
/// assert_eq!(mesh.positions.len(), 4); // the unreferenced vertex is kept
/// let err = gregvox::mesh::load_obj(dir.join("missing.obj")).unwrap_err().to_string();
/// assert!(err.contains("missing.obj"));
/// ```
pub fn load_obj(path: impl AsRef<Path>) -> Result<Mesh> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse_obj_bytes(&bytes, path)
}

/// Parses OBJ text held in memory; `path` only names the source in error messages.
///
/// ```
/// use gregvox::mesh::parse_obj;
/// let m = parse_obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n", "quad.obj").unwrap();
/// assert_eq!(m.face(0), &[0, 1, 2, 3]);
/// let err = parse_obj("v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n", "bad.obj").unwrap_err();
/// assert_eq!(err.to_string(), "bad.obj: line 3: vertex 3 has a non-finite coordinate (NaN)");
/// ```
pub fn parse_obj(text: &str, path: impl AsRef<Path>) -> Result<Mesh> {
    parse_obj_bytes(text.as_bytes(), path.as_ref())
}

pub(crate) fn parse_obj_bytes(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let err = |line: usize, msg: String| Error::parse(path, format!("line {line}: {msg}"));
    if let Some(pos) = bytes.iter().position(|&b| b == 0) {
        let line = 1 + bytes[..pos].iter().filter(|&&b| b == b'\n').count();
        return Err(err(
            line,
            "binary data (NUL byte); not an OBJ text file".into(),
        ));
    }
    let text = match std::str::from_utf8(bytes) {
        Ok(t) => t,
        Err(e) => {
            let pos = e.valid_up_to();
            let line = 1 + bytes[..pos].iter().filter(|&&b| b == b'\n').count();
            return Err(err(line, "invalid UTF-8; not an OBJ text file".into()));
        }
    };
    // A UTF-8 byte-order mark (Windows exporters write one) is not part of the first line: skipped, so the
    // first `v` line is read as one.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut positions: Vec<DVec3> = Vec::new();
    let mut face_ptr = vec![0u32];
    let mut indices: Vec<u32> = Vec::new();
    let mut face_line: Vec<u32> = Vec::new();
    for (ln, raw) in text.lines().enumerate() {
        let line_no = ln + 1;
        let content = raw.split('#').next().unwrap_or("");
        let mut tok = content.split_whitespace();
        let Some(key) = tok.next() else { continue };
        match key {
            "v" => {
                let mut c = [0.0f64; 3];
                for (k, slot) in c.iter_mut().enumerate() {
                    let t = tok.next().ok_or_else(|| {
                        err(line_no, format!("vertex has {k} coordinates (needs 3)"))
                    })?;
                    *slot = t.parse::<f64>().map_err(|_| {
                        err(
                            line_no,
                            format!("cannot read vertex coordinate '{t}' as a number"),
                        )
                    })?;
                }
                let p = DVec3::from(c);
                if !p.is_finite() {
                    let bad = c.iter().find(|x| !x.is_finite()).unwrap();
                    return Err(err(
                        line_no,
                        format!(
                            "vertex {} has a non-finite coordinate ({bad})",
                            positions.len() + 1
                        ),
                    ));
                }
                if positions.len() >= u32::MAX as usize {
                    return Err(err(line_no, "too many vertices for u32 indices".into()));
                }
                positions.push(p);
            }
            "f" => {
                let start = indices.len();
                for t in tok {
                    let first = t.split('/').next().unwrap_or("");
                    let i: i64 = first.parse().map_err(|_| {
                        err(
                            line_no,
                            format!("cannot read face vertex '{t}' as an index"),
                        )
                    })?;
                    let idx = if i > 0 {
                        i - 1
                    } else if i < 0 {
                        // Relative index: -1 is the last vertex defined so far.
                        let r = positions.len() as i64 + i;
                        if r < 0 {
                            return Err(err(
                                line_no,
                                format!(
                                    "relative face index {i} points before the first vertex ({} defined so far)",
                                    positions.len()
                                ),
                            ));
                        }
                        r
                    } else {
                        return Err(err(
                            line_no,
                            "face index 0 is invalid (OBJ indices start at 1)".into(),
                        ));
                    };
                    if idx >= u32::MAX as i64 {
                        return Err(err(line_no, format!("face index {i} is too large")));
                    }
                    indices.push(idx as u32);
                }
                let n = indices.len() - start;
                if n < 3 {
                    return Err(err(
                        line_no,
                        format!("face has {n} vertices (a face needs at least 3)"),
                    ));
                }
                if indices.len() >= u32::MAX as usize {
                    return Err(err(line_no, "too many face corners for u32 indices".into()));
                }
                face_ptr.push(indices.len() as u32);
                face_line.push(line_no as u32);
            }
            _ => {}
        }
    }
    if positions.is_empty() && face_line.is_empty() {
        return Err(Error::parse(path, "empty mesh: no vertices and no faces"));
    }
    if face_line.is_empty() {
        return Err(Error::parse(
            path,
            format!("empty mesh: {} vertices but no faces", positions.len()),
        ));
    }
    // Indices are checked after the whole file is read: OBJ does not forbid forward references.
    for (f, &line) in face_line.iter().enumerate() {
        let face = &indices[face_ptr[f] as usize..face_ptr[f + 1] as usize];
        if let Some(msg) = check_face(face, positions.len(), 1) {
            return Err(err(line as usize, format!("face {}: {msg}", f + 1)));
        }
    }
    Ok(Mesh {
        positions,
        face_ptr,
        indices,
    })
}

/// Writes `mesh` as OBJ (`v` lines with shortest round-trip `f64` text, then 1-based `f` lines), to a
/// temporary file beside `path` that is then renamed, so a reader never sees a half-written file.
///
/// ```
/// # use gregvox::mesh::{Mesh, write_obj, load_obj}; use glam::DVec3;
/// let m = Mesh::from_polygons(vec![DVec3::ZERO, DVec3::X, DVec3::new(0.1, 0.7, 1e-9)], &[vec![0, 1, 2]]).unwrap();
/// let path = std::env::temp_dir().join("gregvox-doc-write.obj");
/// write_obj(&path, &m).unwrap();
/// assert_eq!(load_obj(&path).unwrap(), m); // exact round trip
/// ```
pub fn write_obj(path: impl AsRef<Path>, mesh: &Mesh) -> Result<()> {
    crate::io::write_atomic(path.as_ref(), |w| {
        for p in &mesh.positions {
            writeln!(w, "v {:?} {:?} {:?}", p.x, p.y, p.z)?;
        }
        for f in 0..mesh.n_faces() {
            w.write_all(b"f")?;
            for &v in mesh.face(f) {
                write!(w, " {}", v as u64 + 1)?;
            }
            w.write_all(b"\n")?;
        }
        Ok(())
    })
}

/// Welds vertices closer than `tol` (Chebyshev distance per axis ≤ `tol`, a cube, so the result does not
/// depend on rounding of a Euclidean norm). Each vertex is merged into the first earlier kept vertex
/// within `tol` (file order decides, deterministic); kept vertices keep their relative order and unreferenced
/// vertices are kept. Repeated vertices inside a face are removed; faces left with < 3 vertices are dropped.
/// Returns the welded mesh and `old → new` vertex ids.
///
/// ```
/// # use gregvox::mesh::{Mesh, weld}; use glam::DVec3;
/// let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::X, DVec3::ONE];
/// let m = Mesh::from_polygons(p, &[vec![0, 1, 2], vec![3, 4, 2]]).unwrap();
/// let (w, map) = weld(&m, 1e-9);
/// assert_eq!(w.positions.len(), 4);
/// assert_eq!(map, vec![0, 1, 2, 1, 3]);
/// assert_eq!(w.face(1), &[1, 3, 2]);
/// ```
pub fn weld(mesh: &Mesh, tol: f64) -> (Mesh, Vec<u32>) {
    let tol = tol.max(0.0);
    let cell = if tol > 0.0 { 2.0 * tol } else { 1.0 };
    let key = |p: DVec3| -> [i64; 3] {
        if tol > 0.0 {
            [
                (p.x / cell).floor() as i64,
                (p.y / cell).floor() as i64,
                (p.z / cell).floor() as i64,
            ]
        } else {
            // + 0.0 turns -0.0 into 0.0, so exact welding merges the two zeros.
            [
                (p.x + 0.0).to_bits() as i64,
                (p.y + 0.0).to_bits() as i64,
                (p.z + 0.0).to_bits() as i64,
            ]
        }
    };
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut map = Vec::with_capacity(mesh.positions.len());
    let mut kept: Vec<DVec3> = Vec::new();
    for &p in &mesh.positions {
        let k = key(p);
        let mut found = None;
        if tol > 0.0 {
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        if let Some(list) = grid.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) {
                            for &q in list {
                                let d = (kept[q as usize] - p).abs();
                                if d.max_element() <= tol && found.is_none_or(|f: u32| q < f) {
                                    found = Some(q);
                                }
                            }
                        }
                    }
                }
            }
        } else if let Some(list) = grid.get(&k) {
            found = list.first().copied();
        }
        match found {
            Some(q) => map.push(q),
            None => {
                let id = kept.len() as u32;
                kept.push(p);
                grid.entry(k).or_default().push(id);
                map.push(id);
            }
        }
    }
    let mut face_ptr = vec![0u32];
    let mut indices = Vec::with_capacity(mesh.indices.len());
    for f in 0..mesh.n_faces() {
        let start = indices.len();
        for &v in mesh.face(f) {
            let n = map[v as usize];
            if !indices[start..].contains(&n) {
                indices.push(n);
            }
        }
        if indices.len() - start < 3 {
            indices.truncate(start);
        } else {
            face_ptr.push(indices.len() as u32);
        }
    }
    (
        Mesh {
            positions: kept,
            face_ptr,
            indices,
        },
        map,
    )
}
