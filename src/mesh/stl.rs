//! STL reading, ASCII and binary, written here rather than with `stl_io`.
//!
//! Invariants: triangles in file order, winding as written (the stored normals are ignored, as every
//! reader does), corners welded exactly (`super::load`: STL has no shared vertices); binary coordinates
//! are the file's `f32` widened to `f64`, ASCII ones the decimal text read as `f64`. Errors name the file,
//! then `byte N` (binary) or `line N` (ASCII), then the problem.
//!
//! Binary or ASCII: binary when the length is exactly `84 + 50·n` for the header's count `n`, whatever the
//! header says (exporters often start binary headers with `solid`); ASCII when the file starts with the
//! word `solid` and is text; otherwise binary, whose count must then match the length. A count that does
//! not match is refused before anything is allocated (a triangle is 50 bytes; a lying count cannot make
//! the reader reserve more than the file holds).
//!
//! Why not `stl_io` (0.11): it takes a file starting with `solid ` as ASCII, so binary files with such a
//! header fail; it trusts the binary count (its indexed reader reserves from it); and its errors carry
//! neither a line nor a byte offset. The format is small enough to read here, with all of that right.
use super::load::{numbered_lines, text_of, weld_exact};
use super::Mesh;
use crate::error::{Error, Result};
use glam::DVec3;
use std::path::Path;

/// Bytes of the binary header (80) and the triangle count (4).
const HEADER: u64 = 84;
/// Bytes of one binary triangle: normal, three corners (12 `f32`) and the attribute count (`u16`).
const TRIANGLE: u64 = 50;

/// Whether `bytes` is a binary STL by length: 84 + 50 × the header's count.
pub(crate) fn is_binary_stl(bytes: &[u8]) -> bool {
    bytes.len() as u64 >= HEADER
        && HEADER + TRIANGLE * u64::from(read_u32(bytes, 80)) == bytes.len() as u64
}

fn read_u32(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

fn starts_with_solid(bytes: &[u8]) -> bool {
    let b = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    let start = b
        .iter()
        .position(|c| !c.is_ascii_whitespace())
        .unwrap_or(b.len());
    let b = &b[start..];
    b.len() >= 5
        && b[..5].eq_ignore_ascii_case(b"solid")
        && b.get(5).is_none_or(|c| c.is_ascii_whitespace())
}

/// Reads STL (either kind; see the module doc).
pub(crate) fn parse_stl(bytes: &[u8], path: &Path) -> Result<Mesh> {
    if is_binary_stl(bytes) || !starts_with_solid(bytes) {
        return parse_binary(bytes, path);
    }
    let is_text = !bytes.contains(&0) && std::str::from_utf8(bytes).is_ok();
    if !is_text && bytes.len() as u64 >= HEADER {
        // A binary file whose header starts with `solid` but whose count does not match its length.
        let n = read_u32(bytes, 80);
        return Err(Error::parse(
            path,
            format!(
                "byte 80: neither ASCII STL (binary data after 'solid') nor binary STL (the header claims \
                 {n} triangles, which need {} bytes, but the file has {})",
                HEADER + TRIANGLE * u64::from(n),
                bytes.len()
            ),
        ));
    }
    parse_ascii(bytes, path)
}

fn parse_binary(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let len = bytes.len() as u64;
    let err = |at: u64, msg: String| Error::parse(path, format!("byte {at}: {msg}"));
    if len < HEADER {
        return Err(err(
            len,
            format!(
                "file ends inside the 84-byte binary STL header ({len} bytes; and it is not ASCII STL, \
                 which starts with 'solid')"
            ),
        ));
    }
    let n = u64::from(read_u32(bytes, 80));
    let need = HEADER + TRIANGLE * n;
    if need != len {
        return Err(err(
            80,
            format!(
                "the binary STL header claims {n} triangles, which need {need} bytes, but the file has \
                 {len} ({})",
                if need > len {
                    "truncated, or not an STL file"
                } else {
                    "a wrong count, or not an STL file"
                }
            ),
        ));
    }
    if n == 0 {
        return Err(err(80, "empty mesh: the header claims 0 triangles".into()));
    }
    if 3 * n >= u64::from(u32::MAX) {
        return Err(err(
            80,
            format!("{n} triangles are too many for u32 indices"),
        ));
    }
    // n ≤ len / 50, so this reserves at most 1.5 × the file's size.
    let mut positions = Vec::with_capacity(3 * n as usize);
    for t in 0..n {
        let at = HEADER + TRIANGLE * t;
        for corner in 0..3u64 {
            let c = (at + 12 + 12 * corner) as usize;
            let f = |k: usize| {
                f64::from(f32::from_le_bytes(
                    bytes[c + 4 * k..c + 4 * k + 4].try_into().unwrap(),
                ))
            };
            let p = DVec3::new(f(0), f(1), f(2));
            if !p.is_finite() {
                let bad = [p.x, p.y, p.z]
                    .into_iter()
                    .find(|x| !x.is_finite())
                    .unwrap();
                return Err(err(
                    c as u64,
                    format!(
                        "triangle {} corner {} has a non-finite coordinate ({bad})",
                        t + 1,
                        corner + 1
                    ),
                ));
            }
            positions.push(p);
        }
    }
    finish(positions, path, |t| {
        format!("byte {}: triangle {}", HEADER + TRIANGLE * t as u64, t + 1)
    })
}

/// Triangles `3t, 3t+1, 3t+2` over `positions`, welded; `describe(t)` locates triangle `t` (0-based).
fn finish(positions: Vec<DVec3>, path: &Path, describe: impl Fn(usize) -> String) -> Result<Mesh> {
    let n = positions.len() / 3;
    let mesh = Mesh {
        face_ptr: (0..=n as u32).map(|t| 3 * t).collect(),
        indices: (0..3 * n as u32).collect(),
        positions,
    };
    weld_exact(&mesh, path, describe, |_| false)
}

/// Whitespace-separated words of a text with their line numbers, and the line of the last word taken.
struct Words<'a, I: Iterator<Item = (usize, &'a str)>> {
    lines: I,
    current: std::str::SplitWhitespace<'a>,
    line: usize,
}

impl<'a, I: Iterator<Item = (usize, &'a str)>> Words<'a, I> {
    fn next(&mut self) -> Option<&'a str> {
        loop {
            if let Some(w) = self.current.next() {
                return Some(w);
            }
            let (n, l) = self.lines.next()?;
            self.line = n;
            self.current = l.split_whitespace();
        }
    }
    /// Drops the rest of the current line (a solid's name).
    fn skip_line(&mut self) {
        self.current = "".split_whitespace();
    }
}

fn parse_ascii(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let text = text_of(bytes, path, "ASCII STL", 1)?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut w = Words {
        lines: numbered_lines(text, 1),
        current: "".split_whitespace(),
        line: 1,
    };
    let err = |line: usize, msg: String| Error::parse(path, format!("line {line}: {msg}"));
    let mut positions: Vec<DVec3> = Vec::new();
    let mut lines_of: Vec<u32> = Vec::new();
    let mut solids = 0usize;
    loop {
        match w.next() {
            None if solids > 0 => break,
            None => return Err(err(w.line, "file ends before 'solid'".into())),
            Some(s) if s.eq_ignore_ascii_case("solid") => {}
            Some(s) => {
                return Err(err(
                    w.line,
                    format!("expected 'solid' (or the end of the file), found '{s}'"),
                ))
            }
        }
        solids += 1;
        w.skip_line();
        loop {
            let Some(word) = w.next() else {
                return Err(err(
                    w.line,
                    "file ends inside a solid (truncated? no 'endsolid')".into(),
                ));
            };
            if word.eq_ignore_ascii_case("endsolid") {
                w.skip_line();
                break;
            }
            if !word.eq_ignore_ascii_case("facet") {
                return Err(err(
                    w.line,
                    format!("expected 'facet' or 'endsolid', found '{word}'"),
                ));
            }
            let facet_line = w.line;
            let t = lines_of.len() + 1;
            expect(&mut w, path, t, "normal")?;
            for _ in 0..3 {
                // The stored normal is not used; it must still be there.
                number(&mut w, path, t, "normal")?;
            }
            expect(&mut w, path, t, "outer")?;
            expect(&mut w, path, t, "loop")?;
            for corner in 1..=3 {
                expect(&mut w, path, t, "vertex")?;
                let mut c = [0.0; 3];
                for slot in &mut c {
                    *slot = number(&mut w, path, t, "vertex")?;
                }
                let p = DVec3::from(c);
                if !p.is_finite() {
                    let bad = c.iter().find(|x| !x.is_finite()).unwrap();
                    return Err(err(
                        w.line,
                        format!("triangle {t} corner {corner} has a non-finite coordinate ({bad})"),
                    ));
                }
                positions.push(p);
            }
            expect(&mut w, path, t, "endloop")?;
            expect(&mut w, path, t, "endfacet")?;
            if positions.len() as u64 >= u64::from(u32::MAX) {
                return Err(err(w.line, "too many triangles for u32 indices".into()));
            }
            lines_of.push(facet_line as u32);
        }
    }
    if positions.is_empty() {
        return Err(err(w.line, "empty mesh: no facets".into()));
    }
    finish(positions, path, |t| {
        format!("line {}: triangle {}", lines_of[t], t + 1)
    })
}

/// The next word, which must be `what` (any case), in triangle `t`.
fn expect<'a, I: Iterator<Item = (usize, &'a str)>>(
    w: &mut Words<'a, I>,
    path: &Path,
    t: usize,
    what: &str,
) -> Result<()> {
    match w.next() {
        Some(s) if s.eq_ignore_ascii_case(what) => Ok(()),
        Some(s) => Err(Error::parse(
            path,
            format!(
                "line {}: triangle {t}: expected '{what}', found '{s}'",
                w.line
            ),
        )),
        None => Err(Error::parse(
            path,
            format!(
                "line {}: file ends inside triangle {t} (expected '{what}')",
                w.line
            ),
        )),
    }
}

/// The next word as a number (a coordinate of `what`, in triangle `t`).
fn number<'a, I: Iterator<Item = (usize, &'a str)>>(
    w: &mut Words<'a, I>,
    path: &Path,
    t: usize,
    what: &str,
) -> Result<f64> {
    match w.next() {
        Some(s) => s.parse::<f64>().map_err(|_| {
            Error::parse(
                path,
                format!(
                    "line {}: triangle {t}: cannot read {what} coordinate '{s}' as a number",
                    w.line
                ),
            )
        }),
        None => Err(Error::parse(
            path,
            format!(
                "line {}: file ends inside triangle {t} (expected a {what} coordinate)",
                w.line
            ),
        )),
    }
}
