//! One entry point for every mesh file: [`load_mesh_file`] detects the format and hands the bytes to its
//! reader (OBJ, STL, PLY, OFF, glTF 2.0 / GLB).
//!
//! Invariants of the loaded [`Mesh`] (every format):
//! - Every coordinate is finite, every face has ≥ 3 distinct in-range vertices, there is at least one
//!   face. Anything else is one [`Error::Parse`] naming the file, then where (`line N` for text, `byte N`
//!   for binary data, the glTF object for glTF), then the problem. No input panics, and no claimed count
//!   is trusted: a header that claims more items than the bytes left can hold is refused before anything
//!   is allocated for them.
//! - OBJ, PLY and OFF share vertices already: positions and faces are kept exactly as given, in file order
//!   (unreferenced vertices kept, polygons kept).
//! - STL has no shared vertices (three corners a triangle) and glTF exporters split vertices at seams
//!   (UV, normal or material seams, one copy per primitive): those two formats are welded exactly
//!   ([`crate::mesh::weld`] with tolerance 0: bitwise-equal positions, `-0.0 == 0.0`), so their topology
//!   (open/closed, components, boundary loops: `gregvox mesh --json`) is that of the OBJ of the same mesh.
//!   Kept vertices are in first-use order. A triangle that welding collapses (two corners at the same
//!   position: real STL exports carry such slivers) is dropped with a warning (silently in glTF strips and
//!   fans, where degenerate triangles are the usual way to join strips); a mesh with no face left is
//!   refused.
//!
//! Format detection, content first (a file's name can lie, its bytes cannot):
//! 1. binary STL: an 80-byte header and a `u32` triangle count `n` with the file exactly `84 + 50·n` bytes
//!    long (tested first: binary headers often start with `solid`);
//! 2. `glTF` magic: GLB; `ply` first line: PLY; first token `OFF` (or `COFF`, `NOFF`, …): OFF; first
//!    non-blank byte `{`: glTF JSON; first word `solid`: ASCII STL;
//! 3. else the extension (`.obj .stl .ply .off .gltf .glb`, any case);
//! 4. else OBJ (today's behaviour for OBJ text under other names).
use super::{glb, obj, off, ply, stl, weld, Cage, Mesh};
use crate::error::{Error, Result};
use std::path::Path;

/// The mesh file formats [`load_mesh_file`] reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    /// Wavefront OBJ (`v` and `f` lines).
    Obj,
    /// STL, ASCII or binary.
    Stl,
    /// PLY: ASCII, binary little-endian or big-endian.
    Ply,
    /// Object File Format (`OFF`).
    Off,
    /// glTF 2.0 JSON (`.gltf`), buffers external or as `data:` URIs.
    Gltf,
    /// Binary glTF 2.0 (`.glb`).
    Glb,
}

impl MeshFormat {
    /// The format of a file from its content, else its extension, else OBJ (see the module doc).
    ///
    /// ```
    /// use gregvox::mesh::MeshFormat;
    /// use std::path::Path;
    /// assert_eq!(MeshFormat::detect(b"ply\nformat ascii 1.0\n", Path::new("x.obj")), MeshFormat::Ply);
    /// assert_eq!(MeshFormat::detect(b"v 0 0 0\n", Path::new("x.STL")), MeshFormat::Stl);
    /// assert_eq!(MeshFormat::detect(b"v 0 0 0\n", Path::new("x.txt")), MeshFormat::Obj);
    /// ```
    pub fn detect(bytes: &[u8], path: &Path) -> MeshFormat {
        if let Some(f) = Self::from_content(bytes) {
            return f;
        }
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("stl") => MeshFormat::Stl,
            Some("ply") => MeshFormat::Ply,
            Some("off") => MeshFormat::Off,
            Some("gltf") => MeshFormat::Gltf,
            Some("glb") => MeshFormat::Glb,
            _ => MeshFormat::Obj,
        }
    }

    fn from_content(bytes: &[u8]) -> Option<MeshFormat> {
        if stl::is_binary_stl(bytes) {
            return Some(MeshFormat::Stl);
        }
        if bytes.starts_with(b"glTF") {
            return Some(MeshFormat::Glb);
        }
        if bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n") {
            return Some(MeshFormat::Ply);
        }
        let text = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
        let start = text.iter().position(|b| !b.is_ascii_whitespace())?;
        let first = &text[start..];
        if first[0] == b'{' {
            return Some(MeshFormat::Gltf);
        }
        let word_end = first
            .iter()
            .position(|b| b.is_ascii_whitespace() || *b == b'#')
            .unwrap_or(first.len());
        let word = &first[..word_end];
        if off::is_off_keyword(word) {
            return Some(MeshFormat::Off);
        }
        if word.eq_ignore_ascii_case(b"solid") {
            return Some(MeshFormat::Stl);
        }
        None
    }

    /// The format's name in messages.
    pub fn name(self) -> &'static str {
        match self {
            MeshFormat::Obj => "OBJ",
            MeshFormat::Stl => "STL",
            MeshFormat::Ply => "PLY",
            MeshFormat::Off => "OFF",
            MeshFormat::Gltf => "glTF",
            MeshFormat::Glb => "GLB",
        }
    }
}

/// Reads a mesh file of any supported format (see the module doc for detection, welding and errors).
///
/// ```
/// let dir = std::env::temp_dir().join("gregvox-doc-load-mesh-file");
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("tri.off");
/// std::fs::write(&path, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").unwrap();
/// let mesh = gregvox::mesh::load_mesh_file(&path).unwrap();
/// assert_eq!((mesh.positions.len(), mesh.face(0)), (3, &[0, 1, 2][..]));
/// std::fs::write(&path, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n").unwrap();
/// let err = gregvox::mesh::load_mesh_file(&path).unwrap_err().to_string();
/// assert!(err.ends_with("tri.off: line 6: face 0: vertex index 7 is out of range (there are 3 vertices, numbered from 0)"), "{err}");
/// ```
pub fn load_mesh_file(path: impl AsRef<Path>) -> Result<Mesh> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse_mesh_bytes(&bytes, path)
}

/// Reads a subdivision cage from a mesh file of any supported format: OBJ with its OpenSubdiv tag lines
/// (`t crease`, `t corner`, `t hole`, …: [`crate::mesh::parse_obj_cage`]), every other format untagged
/// (they have no such data).
///
/// ```
/// let dir = std::env::temp_dir().join("gregvox-doc-load-cage-file");
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("quad.obj");
/// std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nt hole 1/0/0 0\n").unwrap();
/// let cage = gregvox::mesh::load_cage_file(&path).unwrap();
/// assert_eq!(cage.tags.holes, [0]);
/// ```
pub fn load_cage_file(path: impl AsRef<Path>) -> Result<Cage> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    match MeshFormat::detect(&bytes, path) {
        MeshFormat::Obj => super::tags::parse_obj_cage_bytes(&bytes, path),
        _ => Ok(Cage::from(parse_mesh_bytes(&bytes, path)?)),
    }
}

/// Parses a mesh file held in memory; `path` names it in errors, gives the extension for detection and,
/// for glTF, the folder that external buffers are relative to.
pub fn parse_mesh_bytes(bytes: &[u8], path: &Path) -> Result<Mesh> {
    match MeshFormat::detect(bytes, path) {
        MeshFormat::Obj => obj::parse_obj_bytes(bytes, path),
        MeshFormat::Stl => stl::parse_stl(bytes, path),
        MeshFormat::Ply => ply::parse_ply(bytes, path),
        MeshFormat::Off => off::parse_off(bytes, path),
        MeshFormat::Glb if !bytes.starts_with(b"glTF") => Err(Error::parse(
            path,
            "byte 0: not a GLB file (no 'glTF' magic)",
        )),
        MeshFormat::Gltf | MeshFormat::Glb => glb::parse_gltf(bytes, path),
    }
}

/// Welds exact duplicates (see the module doc) and drops the faces welding collapses: with a warning naming
/// the first (`describe(face)` says where it is), unless `expected(face)` says such faces are normal there
/// (the joins of glTF strips). Refuses a mesh left with no face.
pub(crate) fn weld_exact(
    mesh: &Mesh,
    path: &Path,
    describe: impl Fn(usize) -> String,
    expected: impl Fn(usize) -> bool,
) -> Result<Mesh> {
    let (welded, map) = weld(mesh, 0.0);
    let mut dropped = 0usize;
    let mut first = None;
    for f in 0..mesh.n_faces() {
        let face = mesh.face(f);
        let mapped: Vec<u32> = face.iter().map(|&v| map[v as usize]).collect();
        if obj::first_repeated(&mapped).is_some() && !expected(f) {
            dropped += 1;
            first.get_or_insert(f);
        }
    }
    if welded.n_faces() == 0 {
        return Err(Error::parse(
            path,
            "empty mesh: every triangle is degenerate (two corners at the same position)",
        ));
    }
    if let Some(f) = first {
        // Real STL exports carry slivers whose corners coincide: they have no area and no inside, so they
        // are dropped (an OBJ face naming a vertex twice is refused: there the file says it on purpose).
        log::warn!(
            "{}: skipped {dropped} degenerate triangle(s) with two corners at the same position (the first: {})",
            path.display(),
            describe(f)
        );
    }
    Ok(welded)
}

/// The 1-based line of byte `pos` of `bytes`.
pub(crate) fn line_of(bytes: &[u8], pos: usize) -> usize {
    1 + bytes[..pos.min(bytes.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
}

/// `bytes` as text, or an error naming the line of the first NUL byte or invalid UTF-8 (`what`: the
/// format's name). `first_line` is the line number of `bytes[0]` in the file.
pub(crate) fn text_of<'a>(
    bytes: &'a [u8],
    path: &Path,
    what: &str,
    first_line: usize,
) -> Result<&'a str> {
    if let Some(pos) = bytes.iter().position(|&b| b == 0) {
        return Err(Error::parse(
            path,
            format!(
                "line {}: binary data (NUL byte); not {what} text",
                first_line - 1 + line_of(bytes, pos)
            ),
        ));
    }
    std::str::from_utf8(bytes).map_err(|e| {
        Error::parse(
            path,
            format!(
                "line {}: invalid UTF-8; not {what} text",
                first_line - 1 + line_of(bytes, e.valid_up_to())
            ),
        )
    })
}

/// Lines of `text` with 1-based numbers (`\n` or `\r\n` endings).
pub(crate) fn numbered_lines(text: &str, first_line: usize) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(move |(i, l)| (first_line + i, l))
}
