//! Voxel grid exporters, chosen by file extension: `.binvox`, `.npy` (packed bits + shape), `.nrrd`
//! (uint8), `.raw` (packed bits) with a `.json` sidecar, `.vox` (MagicaVoxel, multi-model scene graph). Every
//! header or sidecar records origin and pitch (`.vox` has no place for them: the `.json` sidecar holds them).
//!
//! Invariants: files are written through `crate::io::write_atomic` (a temporary file and a rename), so an interrupted run never leaves a truncated
//! output; index conventions are those of each format (binvox: x slowest, then z, y fastest).
use super::grid::{Axis, VoxelGrid};
use crate::error::{Error, Result};
use std::io::Write;
use std::path::Path;

/// Writes an output through [`crate::io::write_atomic`] (temporary file + rename; devices written directly).
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    crate::io::write_atomic(path, write)
}

/// The binvox bytes of `grid` (header + run-length data, values 0/1, runs of at most 255 crossing rows).
///
/// ```
/// use gregvox::voxel::{export::binvox_bytes, grid::{Axis, GridFrame, VoxelGrid}};
/// let frame = GridFrame { res: 2, origin: [0.0; 3], side: 1.0 };
/// let mut g = VoxelGrid::empty(frame, Axis::Z);
/// g.set(1, 0, 0, true); // x = 1, y = 0, z = 0: binvox index 1·4 + 0·2 + 0 = 4
/// let b = binvox_bytes(&g);
/// assert!(b.starts_with(b"#binvox 1\ndim 2 2 2\n"));
/// assert!(b.ends_with(b"data\n\x00\x04\x01\x01\x00\x03"));
/// ```
pub fn binvox_bytes(grid: &VoxelGrid) -> Vec<u8> {
    let f = &grid.frame;
    let r = f.res;
    let mut out = format!(
        "#binvox 1\ndim {r} {r} {r}\ntranslate {} {} {}\nscale {}\ndata\n",
        f.origin[0], f.origin[1], f.origin[2], f.side
    )
    .into_bytes();
    // binvox runs y fastest: lay the bits along y so each (x, z) column streams in order.
    let g = grid.to_axis(Axis::Y);
    let w = f.words_per_column() as usize;
    let mut value = 0u8;
    let mut count = 0u32;
    let mut push = |bit: u8, out: &mut Vec<u8>| {
        if bit == value && count < 255 {
            count += 1;
        } else {
            if count > 0 {
                out.extend_from_slice(&[value, count as u8]);
            }
            value = bit;
            count = 1;
        }
    };
    // For bit axis Y the columns are (u, v) = (z, x): word (x·R + z)·W.
    for x in 0..r as usize {
        for z in 0..r as usize {
            let col = &g.words[(x * r as usize + z) * w..][..w];
            for y in 0..r as usize {
                push((col[y / 32] >> (y % 32) & 1) as u8, &mut out);
            }
        }
    }
    if count > 0 {
        out.extend_from_slice(&[value, count as u8]);
    }
    out
}

/// Parses binvox bytes back into a grid (bits along Z).
pub fn parse_binvox(bytes: &[u8]) -> Result<VoxelGrid> {
    let bad = |m: &str| Error::Invalid(format!("not a binvox file: {m}"));
    let mut pos = 0;
    let mut line = || -> Result<String> {
        let end = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .ok_or_else(|| bad("header ends early"))?;
        let l = String::from_utf8_lossy(&bytes[pos..pos + end])
            .trim()
            .to_owned();
        pos += end + 1;
        Ok(l)
    };
    if !line()?.starts_with("#binvox") {
        return Err(bad("no #binvox line"));
    }
    let (mut res, mut origin, mut side) = (0u32, [0.0; 3], 1.0);
    loop {
        let l = line()?;
        let parts: Vec<&str> = l.split_whitespace().collect();
        match parts.first().copied() {
            Some("dim") if parts.len() == 4 => {
                res = parts[1].parse().map_err(|_| bad("dim"))?;
                if parts[2] != parts[1] || parts[3] != parts[1] {
                    return Err(bad("non-cubic dim"));
                }
            }
            Some("translate") if parts.len() == 4 => {
                for a in 0..3 {
                    origin[a] = parts[a + 1].parse().map_err(|_| bad("translate"))?;
                }
            }
            Some("scale") if parts.len() == 2 => {
                side = parts[1].parse().map_err(|_| bad("scale"))?
            }
            Some("data") => break,
            _ => return Err(bad(&format!("unexpected header line '{l}'"))),
        }
    }
    if res == 0 {
        return Err(bad("no dim"));
    }
    let frame = super::grid::GridFrame { res, origin, side };
    let mut g = VoxelGrid::empty(frame, Axis::Z);
    let total = (res as u64).pow(3);
    let mut idx = 0u64;
    for pair in bytes[pos..].chunks(2) {
        if pair.len() != 2 {
            return Err(bad("odd data length"));
        }
        let (v, n) = (pair[0], pair[1] as u64);
        if idx + n > total {
            return Err(bad("runs exceed dim³"));
        }
        if v != 0 {
            for i in idx..idx + n {
                let r = res as u64;
                let (x, z, y) = (i / (r * r), i / r % r, i % r);
                g.set(x as u32, y as u32, z as u32, true);
            }
        }
        idx += n;
    }
    if idx != total {
        return Err(bad("runs do not cover dim³"));
    }
    Ok(g)
}

impl VoxelGrid {
    /// Writes the grid in the format its extension names (see [`write_grid`]).
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        write_grid(self, path.as_ref())
    }
}

/// Writes `grid` to `path` in the format its extension names.
pub fn write_grid(grid: &VoxelGrid, path: &Path) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "binvox" => write_atomically(path, |w| w.write_all(&binvox_bytes(grid))),
        "npy" => {
            write_atomically(path, |w| w.write_all(&npy_bytes(grid)))?;
            write_sidecar(
                grid,
                path,
                "uint8 (x, y, ceil(R/8)): bits of z, little bit order",
            )
        }
        "nrrd" => write_atomically(path, |w| w.write_all(&nrrd_bytes(grid))),
        "vox" => {
            // MAIN's children size is a u32 and every voxel takes 4 bytes: refuse before building the file.
            let n = grid.count();
            if n > VOX_MAX_VOXELS {
                return Err(Error::Invalid(format!(
                    "{}: {n} solid voxels do not fit a .vox file (at most {VOX_MAX_VOXELS}, 4 bytes each \
                     in one chunk of at most 4 GiB); use .binvox, .npy, .nrrd or .raw",
                    path.display()
                )));
            }
            write_atomically(path, |w| w.write_all(&vox_bytes(grid)))?;
            write_sidecar(
                grid,
                path,
                "MagicaVoxel .vox: models of at most 256 per axis; grid voxel (i,j,k) is world voxel \
                 (i,j,k) - floor(R/2); a model of size s with nTRN translation t holds world voxels t - floor(s/2) + xyz",
            )
        }
        "raw" => {
            let g = grid.to_axis(Axis::Z);
            let bytes: Vec<u8> = bytemuck::cast_slice(&g.words).to_vec();
            write_atomically(path, |w| w.write_all(&bytes))?;
            write_sidecar(
                grid,
                path,
                "little-endian u32; word ((y*R + x) * ceil(R/32) + z/32), bit z%32",
            )
        }
        _ => Err(Error::Invalid(format!(
            "{}: unknown voxel format '.{ext}' (use .binvox, .npy, .nrrd, .raw or .vox)",
            path.display()
        ))),
    }
}

/// Writes `PATH.json` beside a `.raw`/`.npy` output: dims, origin, pitch and the bit layout.
fn write_sidecar(grid: &VoxelGrid, path: &Path, layout: &str) -> Result<()> {
    let f = &grid.frame;
    let sidecar = serde_json::json!({
        "format": "gregvox solid voxels",
        "dims": [f.res, f.res, f.res],
        "origin": f.origin,
        "pitch": f.pitch(),
        "side": f.side,
        "voxel_centre": "origin + (index + 0.5) * pitch",
        "layout": layout,
        "solid_voxels": grid.count(),
    });
    let text = serde_json::to_string_pretty(&sidecar).map_err(|e| Error::Invalid(e.to_string()))?;
    write_atomically(&path.with_extension("json"), |w| {
        w.write_all(text.as_bytes())
    })
}

/// NPY (version 1.0): uint8 array of shape (R, R, ceil(R/8)) in C order, the packed bits of z for each (x, y)
/// (`np.unpackbits(a, axis=2, bitorder='little')[:, :, :R]` gives the (x, y, z) occupancy).
pub fn npy_bytes(grid: &VoxelGrid) -> Vec<u8> {
    let f = &grid.frame;
    let r = f.res as usize;
    let zb = r.div_ceil(8);
    // numpy rejects extra header keys: origin and pitch go to the JSON sidecar.
    let dict = format!("{{'descr': '|u1', 'fortran_order': False, 'shape': ({r}, {r}, {zb}), }}");
    let mut h = dict.into_bytes();
    while (10 + h.len() + 1) % 64 != 0 {
        h.push(b' ');
    }
    h.push(b'\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(h.len() as u16).to_le_bytes());
    out.extend_from_slice(&h);
    let g = grid.to_axis(Axis::Z);
    let w = f.words_per_column() as usize;
    for x in 0..r {
        for y in 0..r {
            let col: &[u32] = &g.words[(y * r + x) * w..][..w];
            let bytes: &[u8] = bytemuck::cast_slice(col);
            out.extend_from_slice(&bytes[..zb]);
        }
    }
    out
}

/// NRRD: uint8 (0/1), sizes X Y Z with x fastest, raw encoding, origin and pitch in the header.
pub fn nrrd_bytes(grid: &VoxelGrid) -> Vec<u8> {
    let f = &grid.frame;
    let r = f.res;
    let p = f.pitch();
    let mut out = format!(
        "NRRD0004\ntype: uint8\ndimension: 3\nsizes: {r} {r} {r}\nencoding: raw\nspace dimension: 3\n\
         space directions: ({p},0,0) (0,{p},0) (0,0,{p})\nspace origin: ({},{},{})\n\n",
        f.origin[0] + 0.5 * p,
        f.origin[1] + 0.5 * p,
        f.origin[2] + 0.5 * p
    )
    .into_bytes();
    let g = grid.to_axis(Axis::X);
    let w = f.words_per_column() as usize;
    // Bit axis X: columns (u, v) = (y, z), word (z·R + y)·W: x runs fastest inside each column.
    for z in 0..r as usize {
        for y in 0..r as usize {
            let col = &g.words[(z * r as usize + y) * w..][..w];
            out.extend((0..r as usize).map(|x| (col[x / 32] >> (x % 32) & 1) as u8));
        }
    }
    out
}

/// Largest model edge in a `.vox` file (u8 coordinates).
pub const VOX_MODEL_MAX: u32 = 256;

/// Most solid voxels a `.vox` file can hold: the MAIN chunk's children size is a u32, each voxel is 4 bytes,
/// and 64 MiB are left for the per-model headers, the scene graph and the palette.
pub const VOX_MAX_VOXELS: u64 = (u32::MAX as u64 - (64 << 20)) / 4;

fn vox_chunk(out: &mut Vec<u8>, id: &[u8; 4], content: &[u8], children: &[u8]) {
    out.extend_from_slice(id);
    out.extend_from_slice(&(content.len() as u32).to_le_bytes());
    out.extend_from_slice(&(children.len() as u32).to_le_bytes());
    out.extend_from_slice(content);
    out.extend_from_slice(children);
}

fn vox_string(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(&(s.len() as u32).to_le_bytes());
    out.extend_from_slice(s.as_bytes());
}

fn vox_dict(out: &mut Vec<u8>, pairs: &[(&str, String)]) {
    out.extend_from_slice(&(pairs.len() as u32).to_le_bytes());
    for (k, v) in pairs {
        vox_string(out, k);
        vox_string(out, v);
    }
}

/// MagicaVoxel `.vox` (version 150 chunks + the 0.99 scene graph) of `grid`, colour index 1 for every voxel.
///
/// The grid is cut into models of at most [`VOX_MODEL_MAX`] per axis (u8 coordinates); each model is placed
/// by an `nTRN` whose `_t` is its centre in MagicaVoxel's convention (a model of size s at translation t
/// covers world voxels `t − ⌊s/2⌋ … t − ⌊s/2⌋ + s − 1`), under one `nGRP`. World voxel = grid voxel − ⌊R/2⌋ on
/// every axis, which keeps R ≤ 2048 inside MagicaVoxel's ±1000 world. Axes are kept as they are (x, y, z; z
/// is up in MagicaVoxel). Models with no voxel are skipped unless the whole grid is empty.
///
/// ```
/// use gregvox::voxel::{export::vox_bytes, grid::{Axis, GridFrame, VoxelGrid}};
/// let mut g = VoxelGrid::empty(GridFrame { res: 2, origin: [0.0; 3], side: 1.0 }, Axis::Z);
/// g.set(1, 0, 1, true);
/// let b = vox_bytes(&g);
/// assert!(b.starts_with(b"VOX \x96\x00\x00\x00MAIN"));
/// let xyzi = b.windows(4).position(|w| w == b"XYZI").unwrap();
/// // one voxel at (1, 0, 1) with colour index 1
/// assert_eq!(&b[xyzi + 12..xyzi + 20], &[1, 0, 0, 0, 1, 0, 1, 1]);
/// ```
pub fn vox_bytes(grid: &VoxelGrid) -> Vec<u8> {
    let f = &grid.frame;
    let r = f.res;
    let g = grid.to_axis(Axis::Z);
    let w = f.words_per_column() as usize;
    let n = r.div_ceil(VOX_MODEL_MAX);
    let half = (r / 2) as i64;
    let mut models: Vec<([u32; 3], [u32; 3], Vec<u8>)> = Vec::new();
    for cx in 0..n {
        for cy in 0..n {
            for cz in 0..n {
                let lo = [cx, cy, cz].map(|c| c * VOX_MODEL_MAX);
                let size = lo.map(|l| (r - l).min(VOX_MODEL_MAX));
                let mut xyzi = Vec::new();
                for y in lo[1]..lo[1] + size[1] {
                    for x in lo[0]..lo[0] + size[0] {
                        // Bits along z: column (u, v) = (x, y), word (y·R + x)·W.
                        let col = &g.words[(y as usize * r as usize + x as usize) * w..][..w];
                        for z in lo[2]..lo[2] + size[2] {
                            if col[z as usize / 32] >> (z % 32) & 1 == 1 {
                                xyzi.extend_from_slice(&[
                                    (x - lo[0]) as u8,
                                    (y - lo[1]) as u8,
                                    (z - lo[2]) as u8,
                                    1,
                                ]);
                            }
                        }
                    }
                }
                if !xyzi.is_empty() {
                    models.push((lo, size, xyzi));
                }
            }
        }
    }
    if models.is_empty() {
        let size = [r.min(VOX_MODEL_MAX); 3];
        models.push(([0; 3], size, Vec::new()));
    }
    let mut children = Vec::new();
    for (_, size, xyzi) in &models {
        let s: Vec<u8> = size.iter().flat_map(|v| v.to_le_bytes()).collect();
        vox_chunk(&mut children, b"SIZE", &s, &[]);
        let mut c = ((xyzi.len() / 4) as u32).to_le_bytes().to_vec();
        c.extend_from_slice(xyzi);
        vox_chunk(&mut children, b"XYZI", &c, &[]);
    }
    // Scene graph: 0 = root nTRN → 1 = nGRP → (2 + 2m) nTRN → (3 + 2m) nSHP(model m).
    let mut c = Vec::new();
    c.extend_from_slice(&0u32.to_le_bytes());
    vox_dict(&mut c, &[]);
    c.extend_from_slice(&1u32.to_le_bytes());
    c.extend_from_slice(&(-1i32).to_le_bytes());
    c.extend_from_slice(&0u32.to_le_bytes()); // layer
    c.extend_from_slice(&1u32.to_le_bytes()); // frames
    vox_dict(&mut c, &[]);
    vox_chunk(&mut children, b"nTRN", &c, &[]);
    let mut c = Vec::new();
    c.extend_from_slice(&1u32.to_le_bytes());
    vox_dict(&mut c, &[]);
    c.extend_from_slice(&(models.len() as u32).to_le_bytes());
    for m in 0..models.len() as u32 {
        c.extend_from_slice(&(2 + 2 * m).to_le_bytes());
    }
    vox_chunk(&mut children, b"nGRP", &c, &[]);
    for (m, (lo, size, _)) in models.iter().enumerate() {
        let m = m as u32;
        let t: Vec<String> = (0..3)
            .map(|a| (lo[a] as i64 + (size[a] / 2) as i64 - half).to_string())
            .collect();
        let mut c = Vec::new();
        c.extend_from_slice(&(2 + 2 * m).to_le_bytes());
        vox_dict(&mut c, &[]);
        c.extend_from_slice(&(3 + 2 * m).to_le_bytes());
        c.extend_from_slice(&(-1i32).to_le_bytes());
        c.extend_from_slice(&0u32.to_le_bytes());
        c.extend_from_slice(&1u32.to_le_bytes());
        vox_dict(&mut c, &[("_t", t.join(" "))]);
        vox_chunk(&mut children, b"nTRN", &c, &[]);
        let mut c = Vec::new();
        c.extend_from_slice(&(3 + 2 * m).to_le_bytes());
        vox_dict(&mut c, &[]);
        c.extend_from_slice(&1u32.to_le_bytes());
        c.extend_from_slice(&m.to_le_bytes());
        vox_dict(&mut c, &[]);
        vox_chunk(&mut children, b"nSHP", &c, &[]);
    }
    // Palette: file colour i is palette index i + 1; index 1 (our voxels) is a warm grey, the rest white.
    let mut rgba = Vec::with_capacity(1024);
    for i in 0..256 {
        rgba.extend_from_slice(if i == 0 {
            &[0xc8, 0xb4, 0x96, 0xff]
        } else {
            &[0xff, 0xff, 0xff, 0xff]
        });
    }
    vox_chunk(&mut children, b"RGBA", &rgba, &[]);
    let mut out = b"VOX ".to_vec();
    out.extend_from_slice(&150u32.to_le_bytes());
    vox_chunk(&mut out, b"MAIN", &[], &children);
    out
}
