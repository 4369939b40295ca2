//! NumPy arrays on disk: reading an (N, 3) float array from `.npy` (the query points) and writing named
//! arrays into an `.npz` (the query results), as `numpy.load` reads them.
//!
//! Invariants: a file is checked whole before anything is allocated from its header (magic, version,
//! a dict with exactly `descr`, `fortran_order` and `shape`, a shape (N, 3) whose byte count the file
//! holds exactly), so a lying header or a truncated file is one clear error naming the file; f4 and f8 of
//! either byte order and C or Fortran order are read; NaN and infinities are the caller's to refuse. The
//! `.npz` is a zip archive of stored (uncompressed) `NAME.npy` entries with CRC-32s, written through
//! [`crate::io::write_atomic`]; archives past the 4 GiB of a zip without its 64-bit extension are refused
//! before writing.
use crate::error::{Error, Result};
use std::path::Path;

/// An array to write: its NumPy `descr`, shape and little-endian bytes.
pub struct Array {
    pub descr: &'static str,
    pub shape: Vec<usize>,
    pub data: Vec<u8>,
}

impl Array {
    /// float64, shape (N,).
    pub fn f64s(v: &[f64]) -> Array {
        Array {
            descr: "<f8",
            shape: vec![v.len()],
            data: v.iter().flat_map(|x| x.to_le_bytes()).collect(),
        }
    }
    /// float64, shape (N, 3).
    pub fn points_f64(v: &[[f64; 3]]) -> Array {
        Array {
            descr: "<f8",
            shape: vec![v.len(), 3],
            data: v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect(),
        }
    }
    /// float64, shape (N, 2) (UVs).
    pub fn f64_rows(v: &[[f64; 2]]) -> Array {
        Array {
            descr: "<f8",
            shape: vec![v.len(), 2],
            data: v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect(),
        }
    }
    /// float32, shape (N,).
    pub fn f32s(v: &[f32]) -> Array {
        Array {
            descr: "<f4",
            shape: vec![v.len()],
            data: v.iter().flat_map(|x| x.to_le_bytes()).collect(),
        }
    }
    /// bool, shape (N,).
    pub fn bools(v: &[bool]) -> Array {
        Array {
            descr: "|b1",
            shape: vec![v.len()],
            data: v.iter().map(|&b| b as u8).collect(),
        }
    }
    /// uint32, shape (N,).
    pub fn u32s(v: &[u32]) -> Array {
        Array {
            descr: "<u4",
            shape: vec![v.len()],
            data: v.iter().flat_map(|x| x.to_le_bytes()).collect(),
        }
    }
    /// float32, shape (N, 3).
    pub fn points_f32(v: &[[f32; 3]]) -> Array {
        Array {
            descr: "<f4",
            shape: vec![v.len(), 3],
            data: v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect(),
        }
    }
    /// float16 (IEEE half, round to nearest even), shape (N, 3).
    pub fn points_f16(v: &[[f32; 3]]) -> Array {
        Array {
            descr: "<f2",
            shape: vec![v.len(), 3],
            data: v
                .iter()
                .flatten()
                .flat_map(|&x| half::f16::from_f32(x).to_le_bytes())
                .collect(),
        }
    }
    /// The bools packed 8 to a byte, first bit in the high bit (`np.packbits`, `np.unpackbits(a)[:N]`
    /// unpacks them): uint8, shape (⌈N/8⌉,).
    pub fn packed_bits(v: &[bool]) -> Array {
        let mut data = vec![0u8; v.len().div_ceil(8)];
        for (i, &b) in v.iter().enumerate() {
            data[i / 8] |= (b as u8) << (7 - i % 8);
        }
        Array {
            descr: "|u1",
            shape: vec![data.len()],
            data,
        }
    }

    /// The `.npy` bytes (version 1.0; header padded to 64 bytes).
    pub fn npy(&self) -> Vec<u8> {
        let mut out = npy_header(self.descr, &self.shape);
        out.extend_from_slice(&self.data);
        out
    }
}

/// An `.npy` (version 1.0) header for an array of `descr` and `shape` in C order, padded to 64 bytes
/// (numpy rejects extra keys in the dict).
pub fn npy_header(descr: &str, shape: &[usize]) -> Vec<u8> {
    let shape = match shape {
        [n] => format!("({n},)"),
        s => format!(
            "({})",
            s.iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let mut h =
        format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}").into_bytes();
    while (10 + h.len() + 1) % 64 != 0 {
        h.push(b' ');
    }
    h.push(b'\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(h.len() as u16).to_le_bytes());
    out.extend_from_slice(&h);
    out
}

/// Writes `arrays` as `path` (an `.npz`: `numpy.load(path)[name]`).
pub fn write_npz(path: &Path, arrays: &[(&str, Array)]) -> Result<()> {
    let bytes =
        npz_bytes(arrays).map_err(|e| Error::Invalid(format!("{}: {e}", path.display())))?;
    crate::io::write_atomic(path, |w| w.write_all(&bytes))
}

/// The bytes of an `.npz` holding `arrays`.
pub fn npz_bytes(arrays: &[(&str, Array)]) -> std::result::Result<Vec<u8>, String> {
    let mut out = Vec::new();
    let mut central = Vec::new();
    for (name, a) in arrays {
        let data = a.npy();
        let file = format!("{name}.npy");
        let offset = out.len();
        if data.len() as u64 + offset as u64 > u32::MAX as u64 - (1 << 20) {
            return Err(format!(
                "the arrays take more than the 4 GiB an .npz without zip64 can hold ({} bytes so far)",
                offset + data.len()
            ));
        }
        let mut crc = flate2::Crc::new();
        crc.update(&data);
        let crc = crc.sum();
        let (size, name_len) = (data.len() as u32, file.len() as u16);
        // Local file header: stored, no data descriptor, DOS date 1980-01-01.
        out.extend_from_slice(&0x0403_4b50u32.to_le_bytes());
        for v in [20u16, 0, 0, 0, 0x21] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in [crc, size, size] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&name_len.to_le_bytes());
        out.extend_from_slice(&0u16.to_le_bytes());
        out.extend_from_slice(file.as_bytes());
        out.extend_from_slice(&data);
        // Its central directory entry.
        central.extend_from_slice(&0x0201_4b50u32.to_le_bytes());
        for v in [20u16, 20, 0, 0, 0, 0x21] {
            central.extend_from_slice(&v.to_le_bytes());
        }
        for v in [crc, size, size] {
            central.extend_from_slice(&v.to_le_bytes());
        }
        for v in [name_len, 0, 0, 0, 0] {
            central.extend_from_slice(&v.to_le_bytes());
        }
        central.extend_from_slice(&0u32.to_le_bytes());
        central.extend_from_slice(&(offset as u32).to_le_bytes());
        central.extend_from_slice(file.as_bytes());
    }
    let (cd_offset, cd_size, n) = (out.len() as u32, central.len() as u32, arrays.len() as u16);
    out.extend_from_slice(&central);
    out.extend_from_slice(&0x0605_4b50u32.to_le_bytes());
    for v in [0u16, 0, n, n] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&cd_size.to_le_bytes());
    out.extend_from_slice(&cd_offset.to_le_bytes());
    out.extend_from_slice(&0u16.to_le_bytes());
    Ok(out)
}

/// Reads an (N, 3) float32/float64 array of points from an `.npy` file.
pub fn read_points(path: &Path) -> Result<Vec<[f64; 3]>> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse_points(&bytes).map_err(|e| Error::Invalid(format!("{}: {e}", path.display())))
}

/// Parses `.npy` bytes holding an (N, 3) float32/float64 array.
pub fn parse_points(bytes: &[u8]) -> std::result::Result<Vec<[f64; 3]>, String> {
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err("not an .npy file (no \\x93NUMPY magic)".into());
    }
    let (start, len) = match bytes[6] {
        1 => (10usize, u16::from_le_bytes([bytes[8], bytes[9]]) as usize),
        2 | 3 if bytes.len() >= 12 => (
            12,
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
        ),
        v => return Err(format!("unsupported .npy version {v}")),
    };
    let end = start
        .checked_add(len)
        .filter(|&e| e <= bytes.len())
        .ok_or("truncated header")?;
    let header = std::str::from_utf8(&bytes[start..end]).map_err(|_| "header is not text")?;
    let field = |key: &str| -> std::result::Result<&str, String> {
        let at = header
            .find(&format!("'{key}'"))
            .ok_or_else(|| format!("header has no '{key}'"))?;
        let rest = header[at + key.len() + 2..].trim_start();
        Ok(rest
            .strip_prefix(':')
            .ok_or("malformed header")?
            .trim_start())
    };
    let descr = field("descr")?;
    let descr = descr
        .strip_prefix('\'')
        .and_then(|d| d.split('\'').next())
        .ok_or("malformed descr")?;
    let (big, size) = match descr {
        "<f4" | "=f4" => (false, 4),
        "<f8" | "=f8" => (false, 8),
        ">f4" => (true, 4),
        ">f8" => (true, 8),
        d => {
            return Err(format!(
                "points must be float32 or float64, not '{d}' (convert with a.astype(np.float32))"
            ))
        }
    };
    let fortran = field("fortran_order")?;
    let fortran = if fortran.starts_with("True") {
        true
    } else if fortran.starts_with("False") {
        false
    } else {
        return Err("malformed fortran_order".into());
    };
    let shape = field("shape")?;
    let inner = shape
        .strip_prefix('(')
        .and_then(|s| s.split(')').next())
        .ok_or("malformed shape")?;
    let dims: Vec<usize> = inner
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.trim_end_matches('L').parse::<usize>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("malformed shape ({inner})"))?;
    let n = match dims.as_slice() {
        [n, 3] => *n,
        _ => return Err(format!("points must have shape (N, 3), not ({inner})")),
    };
    let want = n
        .checked_mul(3 * size)
        .ok_or("the shape's byte count overflows")?;
    let data = &bytes[end..];
    if data.len() != want {
        return Err(format!(
            "shape ({n}, 3) of {descr} needs {want} bytes of data, the file holds {}",
            data.len()
        ));
    }
    let value = |i: usize| -> f64 {
        let b = &data[i * size..(i + 1) * size];
        match (size, big) {
            (4, false) => f32::from_le_bytes(b.try_into().unwrap()) as f64,
            (4, true) => f32::from_be_bytes(b.try_into().unwrap()) as f64,
            (_, false) => f64::from_le_bytes(b.try_into().unwrap()),
            (_, true) => f64::from_be_bytes(b.try_into().unwrap()),
        }
    };
    Ok((0..n)
        .map(|i| {
            std::array::from_fn(|a| {
                if fortran {
                    value(a * n + i)
                } else {
                    value(i * 3 + a)
                }
            })
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_round_trip_and_bad_headers_are_refused() {
        let a = Array::points_f32(&[[1.0, 2.0, 3.0], [4.0, 5.0, 6.5]]);
        let p = parse_points(&a.npy()).unwrap();
        assert_eq!(p, [[1.0, 2.0, 3.0], [4.0, 5.0, 6.5]]);
        let mut lying = a.npy();
        lying.truncate(lying.len() - 1);
        assert!(parse_points(&lying).unwrap_err().contains("needs 24 bytes"));
        let ints = Array::u32s(&[1, 2, 3]);
        assert!(parse_points(&ints.npy()).is_err());
        assert!(parse_points(b"\x93NUMPY\x01\x00\xff\xff").is_err());
        assert!(parse_points(b"hello").is_err());
    }
}
