//! Subdivision tags: what a production cage carries beside positions and faces, as OpenSubdiv's shape
//! format writes it in OBJ files (`t name nints/nfloats/nstrings ints… floats… strings…`, the format of its
//! regression shapes, read by `regression/common/shape_utils.cpp` and applied by `far_utils.h`).
//!
//! Invariants:
//! - A [`Cage`] is a [`Mesh`] and its [`SubdivTags`]; every index in the tags is in range (creases name an
//!   edge of the mesh, corners a vertex, holes a face) and every sharpness is finite. [`Cage::new`] checks
//!   it for library callers, [`parse_obj_cage`] for files (naming the line).
//! - Nothing is dropped silently: a tag line is understood, or refused with a message naming the tag and
//!   the line ([`parse_obj_cage`]); a tag that is understood but has no effect on what gregvox builds
//!   (`facevaryingpropagatecorners`, which OpenSubdiv itself ignores; `facevaryinginterpolateboundary`
//!   on a cage without UVs) is kept and reported by [`SubdivTags::notes`], as are UVs that could not be
//!   kept (some faces without `vt` indices: [`crate::mesh::FaceVarying`]).
//! - What the surface builder cannot honour yet (`smoothtriangles smooth` on a cage with triangles) is
//!   refused there with the tag named ([`SubdivTags::unsupported`]), never smoothed over.
//! - Indices follow OpenSubdiv's tags: 0-based vertices and faces (unlike OBJ's 1-based `f` lines).
//! - Sharpness follows Sdc: ≤ 0 is smooth, ≥ [`SHARPNESS_INFINITE`] (10) is infinitely sharp, in between
//!   is semi-sharp.
//! - Cost: one pass over the lines after the mesh parse, and one hash set of the mesh's edges (O(corners))
//!   to check crease edges; a tag line's argument counts are checked against the line before anything is
//!   allocated from them, so a lying `t crease 999999999/1/0` is an error, not an allocation.
use super::obj::{parse_obj_bytes, Mesh};
use super::uv::{parse_obj_uvs, FVarLinear, FaceVarying};
use crate::error::{Error, Result};
use std::collections::HashSet;
use std::path::Path;

/// Sdc's `Crease::SHARPNESS_INFINITE`: a crease or corner this sharp (or sharper) is infinitely sharp.
pub const SHARPNESS_INFINITE: f32 = 10.0;

/// How boundary edges and corners are interpolated (Sdc `VtxBoundaryInterpolation`; OBJ tag
/// `t interpolateboundary 1/0/0 n`, n = 0 none, 1 edge and corner, 2 edge only).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BoundaryInterpolation {
    /// No boundary interpolation: faces at a boundary vertex whose boundary edges are not all explicitly
    /// infinitely sharp are not drawn (OpenSubdiv makes them holes).
    None,
    /// Boundary edges are infinitely sharp creases (OpenSubdiv's regression default and gregvox's).
    #[default]
    EdgeOnly,
    /// As `EdgeOnly`, and every vertex with one face (a topological corner) is an infinitely sharp corner.
    EdgeAndCorner,
}

/// One crease: the edge between vertices `a` and `b` (0-based) and its sharpness.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crease {
    pub a: u32,
    pub b: u32,
    pub sharpness: f32,
}

/// One sharp vertex (a "corner" tag): vertex (0-based) and sharpness.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CornerTag {
    pub vertex: u32,
    pub sharpness: f32,
}

/// The tags of a cage. `Default` is an untagged cage: smooth, edge-only boundaries.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SubdivTags {
    /// Edge sharpness, in file order (a later tag on the same edge wins, as in OpenSubdiv).
    pub creases: Vec<Crease>,
    /// Vertex sharpness, in file order (a later tag wins).
    pub corners: Vec<CornerTag>,
    /// Faces (0-based) that are holes: not drawn, though they still shape their neighbours.
    pub holes: Vec<u32>,
    /// Boundary interpolation.
    pub boundary: BoundaryInterpolation,
    /// `facevaryinginterpolateboundary` (Sdc `FVarLinearInterpolation`, 0…5) when the file gives it.
    pub fvar_interpolation: Option<u32>,
    /// `creasemethod chaikin` (Sdc `CREASE_CHAIKIN`); only semi-sharp creases depend on it.
    pub chaikin: bool,
    /// `smoothtriangles smooth` (Sdc `TRI_SUB_SMOOTH`); only triangles depend on it.
    pub smooth_triangles: bool,
    /// Tags read that change nothing gregvox builds, with why (see [`SubdivTags::notes`]).
    pub ignored: Vec<String>,
    /// The isolation level L (`--isolation`): the cage is refined L times before the patches are built,
    /// as OpenSubdiv's `RefineAdaptive(L)` isolates every irregular feature to level L. `None`: the least
    /// exact level, ⌈largest semi-sharp sharpness⌉ (at least 1 with non-quad faces, else 0).
    pub isolation: Option<u32>,
    /// (UV cages, Chaikin creasing) per vertex, the semi-sharp edges of the cage vertex it stands for that
    /// it does not have itself (a seam's, other spans'): Chaikin's averaging counts them, as OpenSubdiv's
    /// face-varying channel refines with its cage's edge sharpness
    /// ([`crate::mesh::catmull_clark_matrix_creased_hidden`]). Empty: none anywhere.
    pub hidden_semi_sharp: Vec<Vec<f32>>,
}

/// A subdivision cage: the polygon mesh, its tags and its UVs.
#[derive(Debug, Clone, PartialEq)]
pub struct Cage {
    pub mesh: Mesh,
    pub tags: SubdivTags,
    /// Face-varying UVs (`vt`), interpolated as [`SubdivTags::fvar_linear`] says.
    pub uv: Option<FaceVarying>,
}

impl From<Mesh> for Cage {
    fn from(mesh: Mesh) -> Self {
        Cage {
            mesh,
            tags: SubdivTags::default(),
            uv: None,
        }
    }
}

impl Cage {
    /// A cage from a mesh and tags, checked: every crease names an edge of the mesh, every corner a vertex,
    /// every hole a face, every sharpness is finite.
    ///
    /// ```
    /// use gregvox::mesh::{parse_obj, Cage, Crease, SubdivTags};
    /// let quad = parse_obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n", "q.obj").unwrap();
    /// let mut tags = SubdivTags::default();
    /// tags.creases.push(Crease { a: 0, b: 1, sharpness: 10.0 });
    /// assert!(Cage::new(quad.clone(), tags.clone()).is_ok());
    /// tags.creases.push(Crease { a: 0, b: 2, sharpness: 10.0 }); // a diagonal: no such edge
    /// let err = Cage::new(quad, tags).unwrap_err().to_string();
    /// assert!(err.contains("crease 0 2") && err.contains("not an edge"), "{err}");
    /// ```
    pub fn new(mesh: Mesh, tags: SubdivTags) -> Result<Self> {
        let edges = edge_set(&mesh);
        for c in &tags.creases {
            check_crease(&mesh, &edges, c).map_err(Error::Invalid)?;
        }
        for c in &tags.corners {
            check_corner(&mesh, c).map_err(Error::Invalid)?;
        }
        for &f in &tags.holes {
            check_hole(&mesh, f).map_err(Error::Invalid)?;
        }
        Ok(Cage {
            mesh,
            tags,
            uv: None,
        })
    }

    /// The cage with UVs: `values` and one value index per face corner (the layout of
    /// [`Mesh::indices`]), checked by [`FaceVarying::new`].
    pub fn with_uv(mut self, values: Vec<[f64; 2]>, indices: Vec<u32>) -> Result<Self> {
        self.uv = Some(FaceVarying::new(&self.mesh, values, indices)?);
        Ok(self)
    }
}

impl SubdivTags {
    /// How UVs follow the surface: the `facevaryinginterpolateboundary` tag, or
    /// [`FVarLinear::CornersOnly`] without one.
    pub fn fvar_linear(&self) -> FVarLinear {
        self.fvar_interpolation
            .and_then(FVarLinear::from_tag)
            .unwrap_or_default()
    }

    /// True when the tags change nothing: the cage is the untagged smooth cage.
    pub fn is_plain(&self) -> bool {
        self.creases.iter().all(|c| c.sharpness <= 0.0)
            && self.corners.iter().all(|c| c.sharpness <= 0.0)
            && self.holes.is_empty()
            && self.boundary == BoundaryInterpolation::EdgeOnly
            && !self.smooth_triangles
    }

    /// What the Gregory surface builder cannot honour yet, as one message naming the tag (`None` when
    /// everything can be built exactly): `smoothtriangles smooth` on a cage with triangles.
    ///
    /// ```
    /// use gregvox::mesh::parse_obj_cage;
    /// let c = parse_obj_cage("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nt smoothtriangles 0/0/1 smooth\n", "c.obj").unwrap();
    /// let msg = c.tags.unsupported(&c.mesh).unwrap();
    /// assert!(msg.contains("t smoothtriangles smooth"), "{msg}");
    /// ```
    pub fn unsupported(&self, mesh: &Mesh) -> Option<String> {
        if self.smooth_triangles {
            if let Some(f) = (0..mesh.n_faces()).find(|&f| mesh.face(f).len() == 3) {
                return Some(format!(
                    "t smoothtriangles smooth: the smooth triangle rule (Sdc TRI_SUB_SMOOTH) is not \
                     supported; face {f} is a triangle (the Catmark rule, `smoothtriangles catmark`, is)"
                ));
            }
        }
        None
    }

    /// One line per tag that was read but changes nothing gregvox builds (print them).
    pub fn notes(&self) -> Vec<String> {
        self.ignored.clone()
    }
}

fn edge_set(mesh: &Mesh) -> HashSet<(u32, u32)> {
    let mut s = HashSet::new();
    for f in 0..mesh.n_faces() {
        let face = mesh.face(f);
        for i in 0..face.len() {
            let (a, b) = (face[i], face[(i + 1) % face.len()]);
            s.insert((a.min(b), a.max(b)));
        }
    }
    s
}

fn check_sharpness(s: f32, what: &str) -> std::result::Result<(), String> {
    if s.is_finite() {
        Ok(())
    } else {
        Err(format!("{what}: sharpness {s} is not a finite number"))
    }
}

fn check_crease(
    mesh: &Mesh,
    edges: &HashSet<(u32, u32)>,
    c: &Crease,
) -> std::result::Result<(), String> {
    let what = format!("crease {} {}", c.a, c.b);
    check_sharpness(c.sharpness, &what)?;
    let n = mesh.positions.len() as u32;
    if c.a >= n || c.b >= n {
        return Err(format!(
            "{what}: vertex out of range (the cage has {n} vertices, tags count from 0)"
        ));
    }
    if !edges.contains(&(c.a.min(c.b), c.a.max(c.b))) {
        return Err(format!("{what}: not an edge of the cage"));
    }
    Ok(())
}

fn check_corner(mesh: &Mesh, c: &CornerTag) -> std::result::Result<(), String> {
    let what = format!("corner {}", c.vertex);
    check_sharpness(c.sharpness, &what)?;
    let n = mesh.positions.len() as u32;
    if c.vertex >= n {
        return Err(format!(
            "{what}: vertex out of range (the cage has {n} vertices, tags count from 0)"
        ));
    }
    Ok(())
}

fn check_hole(mesh: &Mesh, f: u32) -> std::result::Result<(), String> {
    if f as usize >= mesh.n_faces() {
        return Err(format!(
            "hole {f}: face out of range (the cage has {} faces, tags count from 0)",
            mesh.n_faces()
        ));
    }
    Ok(())
}

/// Parses OBJ text as a cage: the mesh as [`crate::mesh::parse_obj`] reads it, and its OpenSubdiv tag lines.
///
/// ```
/// use gregvox::mesh::{parse_obj_cage, BoundaryInterpolation};
/// let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n\
///             t crease 2/1/0 0 1 10\nt corner 1/1/0 2 10.0\nt interpolateboundary 1/0/0 1\n";
/// let c = parse_obj_cage(text, "q.obj").unwrap();
/// assert_eq!((c.tags.creases.len(), c.tags.corners.len()), (1, 1));
/// assert_eq!(c.tags.boundary, BoundaryInterpolation::EdgeAndCorner);
/// let err = parse_obj_cage("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nt vertexedit 1/0/0 0\n", "e.obj").unwrap_err();
/// assert!(err.to_string().contains("line 5") && err.to_string().contains("vertexedit"));
/// ```
pub fn parse_obj_cage(text: &str, path: impl AsRef<Path>) -> Result<Cage> {
    parse_obj_cage_bytes(text.as_bytes(), path.as_ref())
}

/// Loads an OBJ file as a cage ([`parse_obj_cage`]); errors name the file.
pub fn load_obj_cage(path: impl AsRef<Path>) -> Result<Cage> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse_obj_cage_bytes(&bytes, path)
}

pub(crate) fn parse_obj_cage_bytes(bytes: &[u8], path: &Path) -> Result<Cage> {
    let mesh = parse_obj_bytes(bytes, path)?;
    // parse_obj_bytes checked NUL bytes and UTF-8.
    let text = std::str::from_utf8(bytes).map_err(|_| Error::parse(path, "invalid UTF-8"))?;
    let err = |line: usize, msg: String| Error::parse(path, format!("line {line}: {msg}"));
    let edges = edge_set(&mesh);
    let mut tags = SubdivTags::default();
    for (ln, raw) in text.lines().enumerate() {
        let line_no = ln + 1;
        let content = raw.split('#').next().unwrap_or("");
        let mut tok = content.split_whitespace();
        if tok.next() != Some("t") {
            continue;
        }
        let tag = parse_tag_line(tok).map_err(|m| err(line_no, m))?;
        apply_tag(&mesh, &edges, &tag, &mut tags).map_err(|m| err(line_no, m))?;
    }
    let (uv, note) = parse_obj_uvs(text, &mesh, path)?;
    tags.ignored.extend(note);
    if uv.is_none() {
        if let Some(n) = tags.fvar_interpolation {
            tags.ignored.push(format!(
                "t facevaryinginterpolateboundary {n}: read; the cage has no UVs, so it changes nothing"
            ));
        }
    }
    Ok(Cage { mesh, tags, uv })
}

/// One `t` line: name and its integer, float and string arguments.
struct Tag<'a> {
    name: &'a str,
    ints: Vec<i64>,
    floats: Vec<f32>,
    strings: Vec<&'a str>,
}

fn parse_tag_line<'a>(
    mut tok: impl Iterator<Item = &'a str>,
) -> std::result::Result<Tag<'a>, String> {
    let name = tok
        .next()
        .ok_or("tag line without a name (expected `t NAME nints/nfloats/nstrings …`)")?;
    let counts = tok
        .next()
        .ok_or_else(|| format!("t {name}: missing the argument counts nints/nfloats/nstrings"))?;
    let parts: Vec<&str> = counts.split('/').collect();
    let n: Vec<usize> = parts
        .iter()
        .map(|p| p.parse::<usize>())
        .collect::<std::result::Result<_, _>>()
        .ok()
        .filter(|n: &Vec<usize>| n.len() == 3)
        .ok_or_else(|| {
            format!("t {name}: cannot read '{counts}' as argument counts nints/nfloats/nstrings")
        })?;
    let rest: Vec<&str> = tok.collect();
    let total = n[0].saturating_add(n[1]).saturating_add(n[2]);
    if rest.len() != total {
        return Err(format!(
            "t {name}: the counts {counts} announce {total} arguments, the line has {}",
            rest.len()
        ));
    }
    let ints = rest[..n[0]]
        .iter()
        .map(|s| {
            s.parse::<i64>()
                .map_err(|_| format!("t {name}: cannot read '{s}' as an integer"))
        })
        .collect::<std::result::Result<_, _>>()?;
    let floats = rest[n[0]..n[0] + n[1]]
        .iter()
        .map(|s| {
            s.parse::<f32>()
                .map_err(|_| format!("t {name}: cannot read '{s}' as a number"))
        })
        .collect::<std::result::Result<_, _>>()?;
    let strings = rest[n[0] + n[1]..].to_vec();
    Ok(Tag {
        name,
        ints,
        floats,
        strings,
    })
}

fn index(i: i64, what: &str) -> std::result::Result<u32, String> {
    u32::try_from(i).map_err(|_| format!("{what}: index {i} is out of range (tags count from 0)"))
}

fn one_int(t: &Tag) -> std::result::Result<i64, String> {
    match t.ints[..] {
        [x] if t.floats.is_empty() && t.strings.is_empty() => Ok(x),
        _ => Err(format!("t {}: expects exactly one integer (1/0/0)", t.name)),
    }
}

fn one_string<'a>(t: &Tag<'a>) -> std::result::Result<&'a str, String> {
    match t.strings[..] {
        [s] if t.ints.is_empty() && t.floats.is_empty() => Ok(s),
        _ => Err(format!("t {}: expects exactly one string (0/0/1)", t.name)),
    }
}

/// The sharpness of item `k` of a tag with `n_items` items: one float for all, or one per item.
fn sharpness_of(t: &Tag, k: usize, n_items: usize) -> std::result::Result<f32, String> {
    let s = match t.floats.len() {
        1 => t.floats[0],
        m if m == n_items => t.floats[k],
        m => {
            return Err(format!(
                "t {}: {m} sharpness values for {n_items} items (give one, or one per item)",
                t.name
            ))
        }
    };
    if !s.is_finite() {
        return Err(format!(
            "t {}: sharpness {s} is not a finite number",
            t.name
        ));
    }
    // OpenSubdiv clamps negative sharpness to 0 (smooth).
    Ok(s.max(0.0))
}

fn apply_tag(
    mesh: &Mesh,
    edges: &HashSet<(u32, u32)>,
    t: &Tag,
    tags: &mut SubdivTags,
) -> std::result::Result<(), String> {
    match t.name {
        "crease" => {
            if t.ints.len() < 2 || t.ints.len() % 2 != 0 || !t.strings.is_empty() {
                return Err(
                    "t crease: expects vertex pairs and sharpness (e.g. `t crease 2/1/0 v0 v1 10`)"
                        .into(),
                );
            }
            let pairs = t.ints.len() / 2;
            for k in 0..pairs {
                let c = Crease {
                    a: index(t.ints[2 * k], "t crease")?,
                    b: index(t.ints[2 * k + 1], "t crease")?,
                    sharpness: sharpness_of(t, k, pairs)?,
                };
                check_crease(mesh, edges, &c).map_err(|m| format!("t {m}"))?;
                tags.creases.push(c);
            }
        }
        "corner" => {
            if t.ints.is_empty() || !t.strings.is_empty() {
                return Err(
                    "t corner: expects vertices and sharpness (e.g. `t corner 1/1/0 v 10`)".into(),
                );
            }
            for k in 0..t.ints.len() {
                let c = CornerTag {
                    vertex: index(t.ints[k], "t corner")?,
                    sharpness: sharpness_of(t, k, t.ints.len())?,
                };
                check_corner(mesh, &c).map_err(|m| format!("t {m}"))?;
                tags.corners.push(c);
            }
        }
        "hole" => {
            if t.ints.is_empty() || !t.floats.is_empty() || !t.strings.is_empty() {
                return Err("t hole: expects face indices (e.g. `t hole 1/0/0 f`)".into());
            }
            for &i in &t.ints {
                let f = index(i, "t hole")?;
                check_hole(mesh, f).map_err(|m| format!("t {m}"))?;
                tags.holes.push(f);
            }
        }
        "interpolateboundary" => {
            tags.boundary = match one_int(t)? {
                0 => BoundaryInterpolation::None,
                1 => BoundaryInterpolation::EdgeAndCorner,
                2 => BoundaryInterpolation::EdgeOnly,
                n => {
                    return Err(format!(
                        "t interpolateboundary: unknown value {n} (0 none, 1 edge and corner, 2 edge only)"
                    ))
                }
            };
        }
        "facevaryinginterpolateboundary" => {
            let n = one_int(t)?;
            if !(0..=5).contains(&n) {
                return Err(format!(
                    "t facevaryinginterpolateboundary: unknown value {n} (0…5, Sdc FVarLinearInterpolation)"
                ));
            }
            tags.fvar_interpolation = Some(n as u32);
        }
        "facevaryingpropagatecorners" => {
            one_int(t)?;
            tags.ignored.push(
                "t facevaryingpropagatecorners: read; OpenSubdiv has no such option and ignores it too"
                    .into(),
            );
        }
        "creasemethod" => {
            tags.chaikin = match one_string(t)? {
                "normal" => false,
                "chaikin" => true,
                s => {
                    return Err(format!(
                        "t creasemethod: unknown method '{s}' (normal or chaikin)"
                    ))
                }
            };
        }
        "smoothtriangles" => {
            tags.smooth_triangles = match one_string(t)? {
                "catmark" => false,
                "smooth" => true,
                s => {
                    return Err(format!(
                        "t smoothtriangles: unknown rule '{s}' (catmark or smooth)"
                    ))
                }
            };
        }
        "vertexedit" | "edgeedit" | "faceedit" => {
            return Err(format!(
                "t {}: hierarchical edits are not supported (OpenSubdiv 3 dropped them too)",
                t.name
            ))
        }
        other => {
            return Err(format!(
                "t {other}: unknown tag (gregvox reads crease, corner, hole, interpolateboundary, \
                 facevaryinginterpolateboundary, facevaryingpropagatecorners, creasemethod, smoothtriangles)"
            ))
        }
    }
    Ok(())
}
