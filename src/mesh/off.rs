//! OFF (Object File Format) reading, by hand (there is no maintained crate, and the format is a dozen
//! lines of grammar).
//!
//! Invariants: positions are the vertex lines' first three numbers in file order, faces the face lines'
//! 0-based index lists in file order, polygons kept; both unchanged (OFF shares vertices, no welding).
//! The grammar read: `#` comments to the end of a line anywhere; blank lines anywhere; a first line `OFF`,
//! `COFF`, `NOFF`, `CNOFF`, `STOFF`, … (or none, for a `.off` file starting with its counts), optionally
//! with the counts on the same line; then `vertices faces edges` (edges ignored); one vertex a line, of
//! which the first three numbers are read (colours, normals, texture coordinates after them are ignored:
//! the `C`/`N`/`ST` variants are read as positions only); one face a line, `n i₁ … iₙ`, with anything after
//! the indices (a face colour) ignored. Refused with a clear error: `4OFF`/`nOFF` (not 3-D), `OFF BINARY`.
//! Errors name the file, then `line N`, then the problem; vertices and faces are numbered from 0 in them,
//! as the file's indices count.
//!
//! Claimed counts are checked before anything is allocated: a vertex line takes at least 6 bytes
//! (`0 0 0` and its newline) and a face line at least 8 (`3 0 1 2`), so counts needing more bytes than
//! follow are refused at once.
use super::load::text_of;
use super::obj::check_face;
use super::Mesh;
use crate::error::{Error, Result};
use glam::DVec3;
use std::path::Path;

/// Whether `word` is an OFF header keyword (`OFF` with optional `ST`, `C`, `N`, `4`, `n` prefixes).
pub(crate) fn is_off_keyword(word: &[u8]) -> bool {
    let Some(prefix) = word.strip_suffix(b"OFF") else {
        return false;
    };
    let mut p = prefix.strip_prefix(b"ST").unwrap_or(prefix);
    for c in [b'C', b'N', b'4', b'n'] {
        p = p.strip_prefix(&[c]).unwrap_or(p);
    }
    p.is_empty()
}

/// Reads OFF (see the module doc).
pub(crate) fn parse_off(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let text = text_of(bytes, path, "OFF", 1)?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let err = |line: usize, msg: String| Error::parse(path, format!("line {line}: {msg}"));
    // Non-blank lines with comments removed, numbered, and the byte offset after each.
    let mut lines = text
        .split_inclusive('\n')
        .scan(0usize, |end, l| {
            *end += l.len();
            Some((*end, l))
        })
        .enumerate()
        .map(|(i, (end, l))| (i + 1, end, l.split('#').next().unwrap_or("").trim()))
        .filter(|(_, _, l)| !l.is_empty());
    let last_line = text.lines().count().max(1);
    let Some((first_no, mut end, first)) = lines.next() else {
        return Err(err(last_line, "empty file: no OFF header".into()));
    };
    let mut words = first.split_whitespace();
    let mut counts_line = first_no;
    let mut counts: Vec<&str> = Vec::new();
    let head = words.next().unwrap_or("");
    if is_off_keyword(head.as_bytes()) {
        if head.contains('4') || head.contains('n') {
            return Err(err(
                first_no,
                format!("'{head}': only 3-D OFF files are supported"),
            ));
        }
        let rest: Vec<&str> = words.collect();
        if rest.first() == Some(&"BINARY") {
            return Err(err(first_no, "binary OFF is not supported".into()));
        }
        if rest.is_empty() {
            let Some((n, e, l)) = lines.next() else {
                return Err(err(
                    last_line,
                    "file ends before the vertex and face counts".into(),
                ));
            };
            counts_line = n;
            end = e;
            counts = l.split_whitespace().collect();
        } else {
            counts = rest;
        }
    } else {
        counts.push(head);
        counts.extend(words);
    }
    let count = |k: usize, what: &str| -> Result<u64> {
        let Some(w) = counts.get(k) else {
            return Err(err(
                counts_line,
                format!(
                    "expected the counts 'vertices faces edges', found {} number(s)",
                    counts.len()
                ),
            ));
        };
        w.parse::<u64>().map_err(|_| {
            err(
                counts_line,
                format!("cannot read the {what} count '{w}' as a number (not an OFF file?)"),
            )
        })
    };
    let nv = count(0, "vertex")?;
    let nf = count(1, "face")?;
    if nv == 0 {
        return Err(err(counts_line, "empty mesh: 0 vertices".into()));
    }
    if nf == 0 {
        return Err(err(
            counts_line,
            format!("empty mesh: {nv} vertices but 0 faces"),
        ));
    }
    let left = (text.len() - end) as u128;
    let need = 6 * u128::from(nv) + 8 * u128::from(nf) - 1;
    if need > left {
        return Err(err(
            counts_line,
            format!(
                "the header claims {nv} vertices and {nf} faces, which need at least {need} bytes, but \
                 only {left} bytes follow (truncated, or a lying count)"
            ),
        ));
    }
    if nv >= u64::from(u32::MAX) {
        return Err(err(
            counts_line,
            format!("{nv} vertices are too many for u32 indices"),
        ));
    }
    let n_verts = nv as usize;
    // Reserved from counts checked against the bytes left: at most 4 × the file's size.
    let mut positions = Vec::with_capacity(n_verts);
    for v in 0..nv {
        let Some((line, _, l)) = lines.next() else {
            return Err(err(
                last_line,
                format!("file ends after {v} of the {nv} vertices the header claims"),
            ));
        };
        let mut w = l.split_whitespace();
        let mut c = [0.0f64; 3];
        for (k, slot) in c.iter_mut().enumerate() {
            let t = w
                .next()
                .ok_or_else(|| err(line, format!("vertex {v} has {k} coordinates (needs 3)")))?;
            *slot = t.parse::<f64>().map_err(|_| {
                err(
                    line,
                    format!("vertex {v}: cannot read coordinate '{t}' as a number"),
                )
            })?;
        }
        let p = DVec3::from(c);
        if !p.is_finite() {
            let bad = c.iter().find(|x| !x.is_finite()).unwrap();
            return Err(err(
                line,
                format!("vertex {v} has a non-finite coordinate ({bad})"),
            ));
        }
        positions.push(p);
    }
    let mut face_ptr = Vec::with_capacity(nf as usize + 1);
    face_ptr.push(0u32);
    let mut indices: Vec<u32> = Vec::with_capacity(3 * nf as usize);
    let mut face: Vec<u32> = Vec::new();
    for f in 0..nf {
        let Some((line, _, l)) = lines.next() else {
            return Err(err(
                last_line,
                format!("file ends after {f} of the {nf} faces the header claims"),
            ));
        };
        let mut w = l.split_whitespace();
        let first = w.next().unwrap_or("");
        let n: u64 = first.parse().map_err(|_| {
            err(
                line,
                format!("face {f}: cannot read the vertex count '{first}' as a number"),
            )
        })?;
        face.clear();
        for k in 0..n {
            let t = w.next().ok_or_else(|| {
                err(
                    line,
                    format!("face {f}: has {k} of the {n} vertex indices it claims"),
                )
            })?;
            let i: u64 = t.parse().map_err(|_| {
                err(
                    line,
                    format!("face {f}: cannot read vertex index '{t}' as an index"),
                )
            })?;
            if i >= nv {
                return Err(err(
                    line,
                    format!(
                        "face {f}: vertex index {i} is out of range (there are {nv} vertices, numbered from 0)"
                    ),
                ));
            }
            face.push(i as u32);
        }
        if let Some(msg) = check_face(&face, n_verts, 0) {
            return Err(err(line, format!("face {f}: {msg}")));
        }
        indices.extend_from_slice(&face);
        if indices.len() >= u32::MAX as usize {
            return Err(err(line, "too many face corners for u32 indices".into()));
        }
        face_ptr.push(indices.len() as u32);
    }
    if let Some((line, _, _)) = lines.next() {
        return Err(err(
            line,
            "data after the last face the header claims (a wrong count?)".into(),
        ));
    }
    Ok(Mesh {
        positions,
        face_ptr,
        indices,
    })
}
