//! Face-varying UVs of a cage: OBJ `vt` values and the per-corner `f v/vt` indices, and the rule that
//! says how they follow the surface (Sdc `FVarLinearInterpolation`, OBJ tag
//! `t facevaryinginterpolateboundary 1/0/0 n`).
//!
//! Invariants:
//! - [`FaceVarying::indices`] has one entry per face corner, in the layout of [`Mesh::indices`] (corner
//!   `k` of the mesh is value `indices[k]`), and every entry is below `values.len()`; every value is finite.
//!   [`FaceVarying::new`] checks it for library callers, [`parse_obj_uvs`] for files (naming the line).
//! - A file whose faces carry `vt` indices on some corners and not on others has no UVs: the reader says
//!   so in a note naming the first face without them, and the surface is built without UVs (the positions
//!   never depend on them).
//! - Cost: one pass over the lines; values and indices are the file's own, nothing is welded.
use super::obj::Mesh;
use crate::error::{Error, Result};
use std::path::Path;

/// How face-varying values follow the surface at their boundaries and seams (Sdc
/// `FVarLinearInterpolation`; the OBJ tag's value in parentheses).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FVarLinear {
    /// (0) Smooth everywhere, seams and boundaries as smooth creases, corners smooth.
    None,
    /// (1) As `None`, with every value that has one face (a UV corner) kept sharp: gregvox's default, as
    /// Blender's ("Keep Corners"); OpenSubdiv's `Sdc::Options` defaults to `All`.
    #[default]
    CornersOnly,
    /// (2) Also sharpens a vertex where three or more UV regions meet (USD's default, "cornersPlus1").
    CornersPlus1,
    /// (3) Also sharpens darts and both values where one of two regions has a corner.
    CornersPlus2,
    /// (4) Linear along every seam and boundary.
    Boundaries,
    /// (5) Bilinear everywhere.
    All,
}

impl FVarLinear {
    /// The rule of the tag value `n` (0…5), `None` past 5.
    pub fn from_tag(n: u32) -> Option<Self> {
        Some(match n {
            0 => FVarLinear::None,
            1 => FVarLinear::CornersOnly,
            2 => FVarLinear::CornersPlus1,
            3 => FVarLinear::CornersPlus2,
            4 => FVarLinear::Boundaries,
            5 => FVarLinear::All,
            _ => return None,
        })
    }

    /// The tag value (0…5).
    pub fn tag(self) -> u32 {
        self as u32
    }
}

/// UVs of a cage: values and one value index per face corner.
///
/// ```
/// use gregvox::mesh::{parse_obj, FaceVarying};
/// let quad = parse_obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n", "q.obj").unwrap();
/// let uv = FaceVarying::new(&quad, vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], vec![0, 1, 2, 3]);
/// assert!(uv.is_ok());
/// let err = FaceVarying::new(&quad, vec![[0.0, 0.0]], vec![0, 1, 0, 0]).unwrap_err().to_string();
/// assert!(err.contains("corner 1") && err.contains("out of range"), "{err}");
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct FaceVarying {
    /// The values (u, v), as the file gives them.
    pub values: Vec<[f64; 2]>,
    /// Per face corner (the layout of [`Mesh::indices`]), the index of its value.
    pub indices: Vec<u32>,
}

impl FaceVarying {
    /// UVs for `mesh`, checked: one index per corner, every index in range, every value finite.
    pub fn new(mesh: &Mesh, values: Vec<[f64; 2]>, indices: Vec<u32>) -> Result<Self> {
        if indices.len() != mesh.indices.len() {
            return Err(Error::Invalid(format!(
                "UVs: {} value indices for {} face corners (one per corner)",
                indices.len(),
                mesh.indices.len()
            )));
        }
        if let Some((k, &i)) = indices
            .iter()
            .enumerate()
            .find(|(_, &i)| i as usize >= values.len())
        {
            return Err(Error::Invalid(format!(
                "UVs: corner {k} names value {i}, out of range ({} values)",
                values.len()
            )));
        }
        if let Some(k) = values
            .iter()
            .position(|v| !v[0].is_finite() || !v[1].is_finite())
        {
            return Err(Error::Invalid(format!(
                "UVs: value {k} ({}, {}) is not finite",
                values[k][0], values[k][1]
            )));
        }
        Ok(FaceVarying { values, indices })
    }
}

/// Reads the UVs of OBJ text whose mesh is `mesh` (as [`crate::mesh::parse_obj`] read it from the same
/// text): `vt u [v [w]]` lines (v defaults to 0, w is ignored) and the second field of each `f` corner
/// (`v/vt`, `v/vt/vn`; negative indices count back from the last `vt` so far). Returns the UVs, or `None`
/// and, when the file has some but not all, a note saying why they were not kept.
pub(crate) fn parse_obj_uvs(
    text: &str,
    mesh: &Mesh,
    path: &Path,
) -> Result<(Option<FaceVarying>, Option<String>)> {
    let err = |line: usize, msg: String| Error::parse(path, format!("line {line}: {msg}"));
    let mut values: Vec<[f64; 2]> = Vec::new();
    let mut indices: Vec<u32> = Vec::with_capacity(mesh.indices.len());
    // Per face: its line and whether its corners carry vt indices (all, none); mixed is an error.
    let mut with = 0usize;
    let mut first_without: Option<(usize, usize)> = None;
    let mut face_lines: Vec<usize> = Vec::new();
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    for (ln, raw) in text.lines().enumerate() {
        let line_no = ln + 1;
        let content = raw.split('#').next().unwrap_or("");
        let mut tok = content.split_whitespace();
        match tok.next() {
            Some("vt") => {
                let mut c = [0.0f64; 2];
                let first = tok
                    .next()
                    .ok_or_else(|| err(line_no, "texture coordinate without values".into()))?;
                for (k, t) in std::iter::once(first).chain(tok.take(1)).enumerate() {
                    c[k] = t.parse::<f64>().map_err(|_| {
                        err(
                            line_no,
                            format!("cannot read texture coordinate '{t}' as a number"),
                        )
                    })?;
                    if !c[k].is_finite() {
                        return Err(err(
                            line_no,
                            format!(
                                "texture coordinate {} has a non-finite value ({})",
                                values.len() + 1,
                                c[k]
                            ),
                        ));
                    }
                }
                if values.len() >= u32::MAX as usize {
                    return Err(err(
                        line_no,
                        "too many texture coordinates for u32 indices".into(),
                    ));
                }
                values.push(c);
            }
            Some("f") => {
                let face = face_lines.len();
                face_lines.push(line_no);
                let mut have = 0usize;
                let mut n = 0usize;
                for t in tok {
                    n += 1;
                    let Some(vt) = t.split('/').nth(1).filter(|s| !s.is_empty()) else {
                        continue;
                    };
                    let i: i64 = vt.parse().map_err(|_| {
                        err(
                            line_no,
                            format!("cannot read texture coordinate index '{vt}' in '{t}'"),
                        )
                    })?;
                    let idx =
                        match i {
                            i if i > 0 => i - 1,
                            i if i < 0 => values.len() as i64 + i,
                            _ => return Err(err(
                                line_no,
                                "texture coordinate index 0 is invalid (OBJ indices start at 1)"
                                    .into(),
                            )),
                        };
                    if idx < 0 || idx >= u32::MAX as i64 {
                        return Err(err(
                            line_no,
                            format!("texture coordinate index {i} is out of range"),
                        ));
                    }
                    indices.push(idx as u32);
                    have += 1;
                }
                if have > 0 && have < n {
                    return Err(err(
                        line_no,
                        format!(
                            "face {}: {have} of its {n} corners name a texture coordinate (all or none)",
                            face + 1
                        ),
                    ));
                }
                if have == n {
                    with += 1;
                } else if first_without.is_none() {
                    first_without = Some((face, line_no));
                }
            }
            _ => {}
        }
    }
    if with == 0 {
        let note = (!values.is_empty()).then(|| {
            format!(
                "{} texture coordinates (vt) but no face names one: the cage has no UVs",
                values.len()
            )
        });
        return Ok((None, note));
    }
    if let Some((face, line)) = first_without {
        return Ok((
            None,
            Some(format!(
                "UVs dropped: face {} (line {line}) names no texture coordinates while {with} faces do",
                face + 1
            )),
        ));
    }
    // Forward references are allowed (as for positions): check once everything is read.
    for (f, &line) in face_lines.iter().enumerate() {
        let (a, b) = (mesh.face_ptr[f] as usize, mesh.face_ptr[f + 1] as usize);
        if let Some(&i) = indices[a..b].iter().find(|&&i| i as usize >= values.len()) {
            return Err(err(
                line,
                format!(
                    "face {}: texture coordinate {} is out of range ({} defined)",
                    f + 1,
                    i as u64 + 1,
                    values.len()
                ),
            ));
        }
    }
    Ok((Some(FaceVarying { values, indices }), None))
}
