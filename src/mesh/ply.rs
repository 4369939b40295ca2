//! PLY reading (ASCII, binary little-endian, binary big-endian), written here rather than with `ply-rs`.
//!
//! Invariants: positions are the `vertex` element's `x`, `y`, `z` in file order (any scalar type: float,
//! double or integers, widened to `f64`); faces are the `face` element's `vertex_indices` (or
//! `vertex_index`) lists in file order, polygons kept; both unchanged (PLY shares vertices, no welding).
//! Other properties and other elements are read past and ignored; a list count and an index may be of
//! any integer type. Errors name the file, then `line N` (the header, ASCII data) or `byte N` (binary
//! data), then the problem; elements are numbered from 0 in them, as the file's indices count.
//!
//! Claimed counts are checked before anything is allocated: every element of a binary body takes at least
//! its fixed size (scalars plus list counts, lists empty), and of an ASCII body at least one word (two
//! bytes) per property, so a header claiming more elements than the bytes after it can hold is refused
//! at once; nothing is ever reserved from a count beyond what those bytes could hold.
//!
//! Why not `ply-rs` (0.1.3, unmaintained since 2018): its header grammar `unwrap`s integer parses (an
//! element count past `usize` panics), it reads a whole file into a generic property map (every value
//! boxed in a hash map), and its errors give neither a line nor a byte offset.
use super::load::text_of;
use super::obj::check_face;
use super::Mesh;
use crate::error::{Error, Result};
use glam::DVec3;
use std::path::Path;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ty {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Ty {
    fn parse(s: &str) -> Option<Ty> {
        Some(match s {
            "char" | "int8" => Ty::I8,
            "uchar" | "uint8" => Ty::U8,
            "short" | "int16" => Ty::I16,
            "ushort" | "uint16" => Ty::U16,
            "int" | "int32" => Ty::I32,
            "uint" | "uint32" => Ty::U32,
            "float" | "float32" => Ty::F32,
            "double" | "float64" => Ty::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Ty::I8 | Ty::U8 => 1,
            Ty::I16 | Ty::U16 => 2,
            Ty::I32 | Ty::U32 | Ty::F32 => 4,
            Ty::F64 => 8,
        }
    }
    fn is_int(self) -> bool {
        !matches!(self, Ty::F32 | Ty::F64)
    }
}

#[derive(Debug)]
enum Prop {
    Scalar(Ty),
    /// A list: count type, item type.
    List(Ty, Ty),
}

#[derive(Debug)]
struct Element {
    name: String,
    count: u64,
    props: Vec<(String, Prop)>,
    /// Header line of the `element` statement.
    line: usize,
}

impl Element {
    /// Bytes an item takes at least in a binary body (lists empty).
    fn min_binary_size(&self) -> u64 {
        self.props
            .iter()
            .map(|(_, p)| match p {
                Prop::Scalar(t) | Prop::List(t, _) => t.size() as u64,
            })
            .sum()
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    /// Byte offset of the body, and its first line.
    body: usize,
    body_line: usize,
}

fn parse_header(bytes: &[u8], path: &Path) -> Result<Header> {
    let err = |line: usize, msg: String| Error::parse(path, format!("line {line}: {msg}"));
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        line_no += 1;
        let Some(len) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err(err(
                line_no,
                "file ends inside the PLY header (no 'end_header' line)".into(),
            ));
        };
        let raw = &bytes[pos..pos + len];
        pos += len + 1;
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        let Ok(line) = std::str::from_utf8(raw) else {
            return Err(err(line_no, "the PLY header is not text".into()));
        };
        let mut tok = line.split_whitespace();
        let key = tok.next().unwrap_or("");
        if line_no == 1 {
            if line.trim_end() != "ply" {
                return Err(err(1, "not a PLY file: the first line is not 'ply'".into()));
            }
            continue;
        }
        match key {
            "" | "comment" | "obj_info" => {}
            "format" => {
                encoding = Some(match tok.next() {
                    Some("ascii") => Encoding::Ascii,
                    Some("binary_little_endian") => Encoding::Little,
                    Some("binary_big_endian") => Encoding::Big,
                    other => {
                        return Err(err(
                            line_no,
                            format!(
                                "unknown PLY format '{}' (ascii, binary_little_endian or binary_big_endian)",
                                other.unwrap_or("")
                            ),
                        ))
                    }
                });
                if tok.next() != Some("1.0") {
                    return Err(err(line_no, "only PLY version 1.0 is supported".into()));
                }
            }
            "element" => {
                let (Some(name), Some(count)) = (tok.next(), tok.next()) else {
                    return Err(err(line_no, "'element' needs a name and a count".into()));
                };
                let count: u64 = count.parse().map_err(|_| {
                    err(
                        line_no,
                        format!("element '{name}': cannot read the count '{count}' as a number"),
                    )
                })?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                    line: line_no,
                });
            }
            "property" => {
                let Some(el) = elements.last_mut() else {
                    return Err(err(line_no, "'property' before any 'element'".into()));
                };
                let bad_type = |t: &str| err(line_no, format!("unknown property type '{t}'"));
                let (prop, name) = match tok.next() {
                    Some("list") => {
                        let (Some(ct), Some(it), Some(name)) = (tok.next(), tok.next(), tok.next())
                        else {
                            return Err(err(
                                line_no,
                                "'property list' needs a count type, an item type and a name"
                                    .into(),
                            ));
                        };
                        let c = Ty::parse(ct).ok_or_else(|| bad_type(ct))?;
                        let i = Ty::parse(it).ok_or_else(|| bad_type(it))?;
                        if !c.is_int() {
                            return Err(err(
                                line_no,
                                format!(
                                    "list '{name}': the count type '{ct}' is not an integer type"
                                ),
                            ));
                        }
                        (Prop::List(c, i), name)
                    }
                    Some(t) => {
                        let ty = Ty::parse(t).ok_or_else(|| bad_type(t))?;
                        let Some(name) = tok.next() else {
                            return Err(err(line_no, "'property' needs a name".into()));
                        };
                        (Prop::Scalar(ty), name)
                    }
                    None => return Err(err(line_no, "'property' needs a type".into())),
                };
                el.props.push((name.to_string(), prop));
            }
            "end_header" => break,
            other => {
                return Err(err(
                    line_no,
                    format!("unknown PLY header keyword '{other}'"),
                ))
            }
        }
    }
    let Some(encoding) = encoding else {
        return Err(err(line_no, "the PLY header has no 'format' line".into()));
    };
    Ok(Header {
        encoding,
        elements,
        body: pos,
        body_line: line_no + 1,
    })
}

/// Where the vertex positions and the face lists are, in the header.
struct Layout {
    vertex: usize,
    xyz: [usize; 3],
    face: usize,
    list: usize,
}

fn layout(h: &Header, path: &Path) -> Result<Layout> {
    let err = |line: usize, msg: String| Error::parse(path, format!("line {line}: {msg}"));
    let find_el = |name: &str| h.elements.iter().position(|e| e.name == name);
    let Some(vertex) = find_el("vertex") else {
        return Err(err(
            h.body_line - 1,
            "empty mesh: no 'vertex' element".into(),
        ));
    };
    let Some(face) = find_el("face") else {
        return Err(err(
            h.body_line - 1,
            "empty mesh: no 'face' element (a point cloud?)".into(),
        ));
    };
    let v = &h.elements[vertex];
    let mut xyz = [0; 3];
    for (k, name) in ["x", "y", "z"].iter().enumerate() {
        xyz[k] = match v.props.iter().position(|(n, _)| n == name) {
            Some(i) if matches!(v.props[i].1, Prop::Scalar(_)) => i,
            Some(_) => {
                return Err(err(
                    v.line,
                    format!("vertex property '{name}' is a list (a coordinate must be a scalar)"),
                ))
            }
            None => {
                return Err(err(
                    v.line,
                    format!("the vertex element has no '{name}' property"),
                ))
            }
        };
    }
    let f = &h.elements[face];
    let list = f
        .props
        .iter()
        .position(|(n, p)| {
            matches!(p, Prop::List(_, t) if t.is_int())
                && (n == "vertex_indices" || n == "vertex_index")
        })
        .ok_or_else(|| {
            err(
                f.line,
                "the face element has no integer 'vertex_indices' (or 'vertex_index') list".into(),
            )
        })?;
    if v.count == 0 {
        return Err(err(v.line, "empty mesh: 0 vertices".into()));
    }
    if f.count == 0 {
        return Err(err(f.line, "empty mesh: 0 faces".into()));
    }
    if v.count >= u64::from(u32::MAX) {
        return Err(err(
            v.line,
            format!("{} vertices are too many for u32 indices", v.count),
        ));
    }
    Ok(Layout {
        vertex,
        xyz,
        face,
        list,
    })
}

/// A value source: the words of an ASCII body, or the bytes of a binary one.
trait Source {
    /// Starts the next item of an element (ASCII: the next non-blank line).
    fn begin(&mut self) -> std::result::Result<(), String>;
    /// Ends an item (ASCII: no word may be left on its line).
    fn end(&mut self) -> std::result::Result<(), String>;
    fn int(&mut self, ty: Ty) -> std::result::Result<i64, String>;
    fn float(&mut self, ty: Ty) -> std::result::Result<f64, String>;
    /// Where the reader is, for messages: `line N` or `byte N`.
    fn at(&self) -> String;
}

struct Ascii<'a> {
    lines: std::iter::Peekable<std::iter::Enumerate<std::str::Lines<'a>>>,
    words: std::str::SplitWhitespace<'a>,
    first_line: usize,
    line: usize,
}

impl Ascii<'_> {
    fn word(&mut self) -> std::result::Result<&str, String> {
        self.words
            .next()
            .ok_or_else(|| "the line has fewer values than the header's properties".to_string())
    }
}

impl Source for Ascii<'_> {
    fn begin(&mut self) -> std::result::Result<(), String> {
        loop {
            let Some((i, l)) = self.lines.next() else {
                return Err(
                    "the file ends before the header's counts are read (truncated?)".into(),
                );
            };
            self.line = self.first_line + i;
            if !l.trim().is_empty() {
                self.words = l.split_whitespace();
                return Ok(());
            }
        }
    }
    fn end(&mut self) -> std::result::Result<(), String> {
        match self.words.next() {
            None => Ok(()),
            Some(w) => Err(format!(
                "'{w}': more values on the line than the header's properties"
            )),
        }
    }
    fn int(&mut self, _ty: Ty) -> std::result::Result<i64, String> {
        let w = self.word()?;
        w.parse::<i64>()
            .map_err(|_| format!("cannot read '{w}' as an integer"))
    }
    fn float(&mut self, ty: Ty) -> std::result::Result<f64, String> {
        let w = self.word()?;
        if ty.is_int() {
            w.parse::<i64>()
                .map(|v| v as f64)
                .map_err(|_| format!("cannot read '{w}' as an integer"))
        } else {
            w.parse::<f64>()
                .map_err(|_| format!("cannot read '{w}' as a number"))
        }
    }
    fn at(&self) -> String {
        format!("line {}", self.line)
    }
}

struct Binary<'a> {
    bytes: &'a [u8],
    pos: usize,
    big: bool,
}

impl Binary<'_> {
    fn take<const N: usize>(&mut self) -> std::result::Result<[u8; N], String> {
        let Some(b) = self.bytes.get(self.pos..self.pos + N) else {
            return Err(format!(
                "the file ends inside the data ({} bytes; truncated?)",
                self.bytes.len()
            ));
        };
        self.pos += N;
        let mut a: [u8; N] = b.try_into().unwrap();
        if self.big {
            a.reverse();
        }
        Ok(a)
    }
    fn value(&mut self, ty: Ty) -> std::result::Result<f64, String> {
        Ok(match ty {
            Ty::I8 => f64::from(i8::from_le_bytes(self.take()?)),
            Ty::U8 => f64::from(u8::from_le_bytes(self.take()?)),
            Ty::I16 => f64::from(i16::from_le_bytes(self.take()?)),
            Ty::U16 => f64::from(u16::from_le_bytes(self.take()?)),
            Ty::I32 => f64::from(i32::from_le_bytes(self.take()?)),
            Ty::U32 => f64::from(u32::from_le_bytes(self.take()?)),
            Ty::F32 => f64::from(f32::from_le_bytes(self.take()?)),
            Ty::F64 => f64::from_le_bytes(self.take()?),
        })
    }
}

impl Source for Binary<'_> {
    fn begin(&mut self) -> std::result::Result<(), String> {
        Ok(())
    }
    fn end(&mut self) -> std::result::Result<(), String> {
        Ok(())
    }
    fn int(&mut self, ty: Ty) -> std::result::Result<i64, String> {
        if !ty.is_int() {
            return Err("a float where an integer is needed".into());
        }
        // Every integer type fits an f64 exactly.
        Ok(self.value(ty)? as i64)
    }
    fn float(&mut self, ty: Ty) -> std::result::Result<f64, String> {
        self.value(ty)
    }
    fn at(&self) -> String {
        format!("byte {}", self.pos)
    }
}

/// Reads PLY (see the module doc).
pub(crate) fn parse_ply(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let h = parse_header(bytes, path)?;
    let lay = layout(&h, path)?;
    let left = (bytes.len() - h.body) as u128;
    // Refuse counts the body cannot hold, before allocating anything for them.
    let (need, unit) = match h.encoding {
        Encoding::Ascii => (
            h.elements
                .iter()
                .map(|e| u128::from(e.count) * e.props.len() as u128)
                .sum::<u128>(),
            "values (a value takes at least 2 bytes of text)",
        ),
        _ => (
            h.elements
                .iter()
                .map(|e| u128::from(e.count) * u128::from(e.min_binary_size()))
                .sum::<u128>(),
            "bytes",
        ),
    };
    let fits = match h.encoding {
        Encoding::Ascii => need <= left.div_ceil(2),
        _ => need <= left,
    };
    if !fits {
        let counts: Vec<String> = h
            .elements
            .iter()
            .map(|e| format!("{} {}", e.count, e.name))
            .collect();
        let at = match h.encoding {
            Encoding::Ascii => format!("line {}", h.body_line),
            _ => format!("byte {}", h.body),
        };
        return Err(Error::parse(
            path,
            format!(
                "{at}: the header claims {}, which need at least {need} {unit}, but only {left} bytes \
                 follow the header (truncated, or a lying count)",
                counts.join(", ")
            ),
        ));
    }
    match h.encoding {
        Encoding::Ascii => {
            let text = text_of(&bytes[h.body..], path, "ASCII PLY", h.body_line)?;
            let mut src = Ascii {
                lines: text.lines().enumerate().peekable(),
                words: "".split_whitespace(),
                first_line: h.body_line,
                line: h.body_line,
            };
            let mesh = read_body(&h, &lay, &mut src, path)?;
            // Anything but blank lines after the last element means the counts do not match the data.
            if let Some((i, _)) = src.lines.find(|(_, l)| !l.trim().is_empty()) {
                return Err(Error::parse(
                    path,
                    format!(
                        "line {}: data after the last element the header declares (a wrong count?)",
                        h.body_line + i
                    ),
                ));
            }
            Ok(mesh)
        }
        enc => {
            let mut src = Binary {
                bytes,
                pos: h.body,
                big: enc == Encoding::Big,
            };
            let mesh = read_body(&h, &lay, &mut src, path)?;
            if src.pos != bytes.len() {
                return Err(Error::parse(
                    path,
                    format!(
                        "byte {}: {} bytes after the last element the header declares (a wrong count?)",
                        src.pos,
                        bytes.len() - src.pos
                    ),
                ));
            }
            Ok(mesh)
        }
    }
}

fn read_body(h: &Header, lay: &Layout, src: &mut dyn Source, path: &Path) -> Result<Mesh> {
    let n_verts = h.elements[lay.vertex].count as usize;
    // Both counts were checked against the bytes left, so these reserve at most a few times the file.
    let mut positions: Vec<DVec3> = Vec::with_capacity(n_verts);
    let n_faces = h.elements[lay.face].count as usize;
    let mut face_ptr: Vec<u32> = Vec::with_capacity(n_faces + 1);
    face_ptr.push(0);
    let mut indices: Vec<u32> = Vec::with_capacity(3 * n_faces);
    let mut face: Vec<u32> = Vec::new();
    for (ei, el) in h.elements.iter().enumerate() {
        if el.props.is_empty() {
            continue; // nothing to read, however many the count says
        }
        for item in 0..el.count {
            let fail = |src: &dyn Source, msg: String| {
                Error::parse(path, format!("{}: {} {item}: {msg}", src.at(), el.name))
            };
            src.begin().map_err(|m| fail(src, m))?;
            let item_at = src.at();
            let mut c = [0.0f64; 3];
            for (pi, (_, prop)) in el.props.iter().enumerate() {
                match *prop {
                    Prop::Scalar(ty) => {
                        let v = src.float(ty).map_err(|m| fail(src, m))?;
                        if ei == lay.vertex {
                            if let Some(k) = lay.xyz.iter().position(|&x| x == pi) {
                                c[k] = v;
                            }
                        }
                    }
                    Prop::List(ct, it) => {
                        let n = src.int(ct).map_err(|m| fail(src, m))?;
                        if n < 0 {
                            return Err(fail(src, format!("negative list length {n}")));
                        }
                        let wanted = ei == lay.face && pi == lay.list;
                        if wanted && n as u64 >= u64::from(u32::MAX) {
                            return Err(fail(src, format!("a list of {n} items is too long")));
                        }
                        face.clear();
                        for _ in 0..n {
                            if !wanted {
                                // Another list (texture coordinates, …): read past, of any type.
                                src.float(it).map_err(|m| fail(src, m))?;
                                continue;
                            }
                            let v = src.int(it).map_err(|m| fail(src, m))?;
                            if v < 0 || v >= n_verts as i64 {
                                return Err(Error::parse(
                                    path,
                                    format!(
                                        "{item_at}: face {item}: vertex index {v} is out of range \
                                         (there are {n_verts} vertices, numbered from 0)"
                                    ),
                                ));
                            }
                            face.push(v as u32);
                        }
                        if wanted {
                            if let Some(msg) = check_face(&face, n_verts, 0) {
                                return Err(Error::parse(
                                    path,
                                    format!("{item_at}: face {item}: {msg}"),
                                ));
                            }
                            indices.extend_from_slice(&face);
                            if indices.len() >= u32::MAX as usize {
                                return Err(fail(
                                    src,
                                    "too many face corners for u32 indices".into(),
                                ));
                            }
                            face_ptr.push(indices.len() as u32);
                        }
                    }
                }
            }
            src.end().map_err(|m| fail(src, m))?;
            if ei == lay.vertex {
                let p = DVec3::from(c);
                if !p.is_finite() {
                    let bad = c.iter().find(|x| !x.is_finite()).unwrap();
                    return Err(Error::parse(
                        path,
                        format!("{item_at}: vertex {item} has a non-finite coordinate ({bad})"),
                    ));
                }
                positions.push(p);
            }
        }
    }
    Ok(Mesh {
        positions,
        face_ptr,
        indices,
    })
}
