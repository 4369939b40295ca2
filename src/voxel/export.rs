//! Voxel grid exporters, chosen by file extension: `.binvox`, `.npy` (a plain `(X, Y, Z)` bool array, or
//! packed bits with [`SaveOptions::npy_packed`]), `.nrrd` (uint8), `.raw` (packed bits), `.vox` (MagicaVoxel,
//! multi-model scene graph), `.vdb` (an OpenVDB `BoolGrid`, `voxel::vdb`); sparse `.npz` (coordinates) and `.ply` (centres); the solid's boundary mesh
//! as `.obj`, `.stl`, `.glb` (`.ply` with [`SaveOptions::ply_boundary`]), built by `voxel::boundary`.
//!
//! Placement (the grid contract of `grid.rs`): voxel (i,j,k) has its centre at origin + (index + ½)·voxel
//! size on each axis. Every output records it: binvox `dim`/`translate`/`scale`, NRRD `sizes`, `space
//! directions` and `space origin` (the centre of voxel 0, as NRRD places samples), and for `.npy`, `.raw`
//! and `.vox` a `PATH.json` sidecar named after the whole file (`a.npy` → `a.npy.json`, so `a.npy` and `a.raw` in one
//! folder keep their own placement) with `dims`, `voxel_size`, `origin` and `index_to_world` (the row-major
//! 4×4 matrix taking (i, j, k, 1) to the voxel's centre).
//!
//! Cost: every encoder works by 32-bit words, never voxel by voxel: the bit axis is changed by 32 × 32 block
//! transposes (`VoxelGrid::to_axis`), `.npy`/`.nrrd` expand a word's bits to bytes by table lookups, and
//! binvox extends runs by whole words of one value and walks mixed words run by run; slabs of the slowest
//! axis run in parallel. Memory is the output's bytes plus one copy of the packed grid. The worst case is
//! binvox on noise (a run every voxel or two: two bytes per run, output up to twice the voxel count);
//! `gregvox bench --suite writers` measures a 1024³ ball and 1024³ hashed noise in every format.
//!
//! Invariants: files are written through `crate::io::write_atomic` (a temporary file and a rename), so an
//! interrupted run never leaves a truncated output; a grid a format cannot hold is refused before anything
//! is written (binvox: cubic grids of cubic voxels only; `.vox`: at most [`VOX_MAX_VOXELS`] voxels); index
//! conventions are those of each format (binvox: x slowest, then z, y fastest).
use super::grid::{Axis, GridFrame, VoxelGrid};
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
/// binvox holds cubic grids of cubic voxels only (`scale` is the cube's side); [`write_grid`] refuses others.
///
/// ```
/// use gregvox::voxel::{export::binvox_bytes, grid::{Axis, GridFrame, VoxelGrid}};
/// let mut g = VoxelGrid::empty(GridFrame::cubic(2, [0.0; 3], 1.0), Axis::Z);
/// g.set(1, 0, 0, true); // x = 1, y = 0, z = 0: binvox index 1·4 + 0·2 + 0 = 4
/// let b = binvox_bytes(&g);
/// assert!(b.starts_with(b"#binvox 1\ndim 2 2 2\n"));
/// assert!(b.ends_with(b"data\n\x00\x04\x01\x01\x00\x03"));
/// ```
pub fn binvox_bytes(grid: &VoxelGrid) -> Vec<u8> {
    let f = &grid.frame;
    let [nx, ny, nz] = f.dims;
    let side = f.voxel_size[0] * nx as f64;
    let mut out = format!(
        "#binvox 1\ndim {nx} {ny} {nz}\ntranslate {} {} {}\nscale {}\ndata\n",
        f.origin[0], f.origin[1], f.origin[2], side
    )
    .into_bytes();
    // binvox runs y fastest: lay the bits along y so each (x, z) column streams in order (bit axis Y's
    // columns are (u, v) = (z, x), stored x-major: the file's order). Slabs of x are encoded in parallel,
    // straight into bytes except their first and last runs, which are joined with the neighbours' here:
    // memory is the output's, whatever the number of runs.
    let g = grid.to_axis(Axis::Y);
    let w = g.frame.words_per_column(Axis::Y) as usize;
    let slab = (nz as usize * w).max(1);
    let slabs: Vec<RunBytes> = {
        use rayon::prelude::*;
        g.words
            .par_chunks(slab * 8)
            .map(|words| {
                let mut runs = RunBytes::default();
                for col in words.chunks(w) {
                    column_runs(col, ny, &mut runs);
                }
                runs
            })
            .collect()
    };
    out.reserve(slabs.iter().map(|r| r.bytes.len() + 4).sum());
    let mut carry: Option<(u8, u64)> = None;
    for r in slabs {
        let Some(first) = r.first else { continue };
        match (carry, r.last) {
            // The slab is one run: it only lengthens or replaces the carry.
            (Some(c), None) if c.0 == first.0 => carry = Some((c.0, c.1 + first.1)),
            (c, None) => {
                if let Some(c) = c {
                    emit_run(&mut out, c);
                }
                carry = Some(first);
            }
            (c, Some(last)) => {
                match c {
                    Some(c) if c.0 == first.0 => emit_run(&mut out, (c.0, c.1 + first.1)),
                    Some(c) => {
                        emit_run(&mut out, c);
                        emit_run(&mut out, first);
                    }
                    None => emit_run(&mut out, first),
                }
                out.extend_from_slice(&r.bytes);
                carry = Some(last);
            }
        }
    }
    if let Some(c) = carry {
        emit_run(&mut out, c);
    }
    out
}

/// A stretch of binvox runs: the first run and the last run held open (a neighbouring stretch may continue
/// them), the ones between already encoded.
#[derive(Default)]
struct RunBytes {
    first: Option<(u8, u64)>,
    bytes: Vec<u8>,
    /// The open run after `first`, if any.
    last: Option<(u8, u64)>,
}

impl RunBytes {
    #[inline]
    fn push(&mut self, value: u8, n: u64) {
        // The common case first: the open run continues, or a new one closes it.
        if let Some(l) = &mut self.last {
            if l.0 == value {
                l.1 += n;
            } else {
                let done = std::mem::replace(l, (value, n));
                emit_run(&mut self.bytes, done);
            }
            return;
        }
        match &mut self.first {
            None => self.first = Some((value, n)),
            Some(f) if f.0 == value => f.1 += n,
            Some(_) => self.last = Some((value, n)),
        }
    }
}

/// Appends run (value, n) as (value, count ≤ 255) pairs.
#[inline]
fn emit_run(out: &mut Vec<u8>, (value, mut n): (u8, u64)) {
    if n <= 255 {
        out.extend_from_slice(&[value, n as u8]);
        return;
    }
    while n > 0 {
        let take = n.min(255);
        out.extend_from_slice(&[value, take as u8]);
        n -= take;
    }
}

/// Appends the runs of one column of `len` bits. Whole words of one value extend a run by 32 at once and
/// mixed words go run by run (trailing zeros and ones), so the cost is per word and per run, never per
/// voxel.
fn column_runs(col: &[u32], len: u32, runs: &mut RunBytes) {
    for (i, &word) in col.iter().enumerate() {
        let bits = (len - 32 * i as u32).min(32);
        let full = if bits == 32 {
            u32::MAX
        } else {
            (1u32 << bits) - 1
        };
        match word & full {
            0 => runs.push(0, bits as u64),
            m if m == full => runs.push(1, bits as u64),
            m => {
                let (mut m, mut left) = (m, bits);
                while left > 0 {
                    let (value, n) = if m & 1 == 1 {
                        (1, m.trailing_ones())
                    } else {
                        (0, m.trailing_zeros())
                    };
                    let n = n.min(left);
                    runs.push(value, n as u64);
                    m = m.checked_shr(n).unwrap_or(0);
                    left -= n;
                }
            }
        }
    }
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
    let frame = super::grid::GridFrame::cubic(res, origin, side);
    frame.validate().map_err(|e| bad(&format!("header: {e}")))?;
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
        write_grid(self, path.as_ref(), &SaveOptions::default())
    }

    /// [`VoxelGrid::save`] with options.
    pub fn save_with(&self, path: impl AsRef<Path>, opts: &SaveOptions) -> Result<()> {
        write_grid(self, path.as_ref(), opts)
    }
}

/// Choices of the exporters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SaveOptions {
    /// `.npy` as packed bits, uint8 of shape (X, Y, ceil(Z/8)), little bit order (`--npy-packed`), instead
    /// of a bool (X, Y, Z) array.
    pub npy_packed: bool,
    /// `.ply` as the solid's boundary mesh (`--ply-boundary`) instead of the solid voxels' centres.
    pub ply_boundary: bool,
}

/// The voxel formats [`write_grid`] knows, by extension: `.obj`, `.stl` and `.glb` (and `.ply` with
/// [`SaveOptions::ply_boundary`]) hold the solid's boundary mesh ([`super::boundary::boundary_mesh`]).
pub const FORMATS: [&str; 11] = [
    "binvox", "glb", "npy", "npz", "nrrd", "obj", "ply", "raw", "stl", "vdb", "vox",
];

/// The formats that hold the solid's boundary as a mesh rather than voxels.
pub const MESH_FORMATS: [&str; 3] = ["glb", "obj", "stl"];

/// Most solid voxels a sparse output (`.npz` coordinates, `.ply` centres) takes: 12 bytes each within the
/// 4 GiB of an `.npz` without zip64.
pub const SPARSE_MAX_VOXELS: u64 = (u32::MAX as u64 - (64 << 20)) / 12;

/// Refuses, before any work, a grid that `path`'s format cannot hold (an unknown extension, a non-cubic grid
/// for binvox, too many voxels for `.vox`). `solid` is the solid-voxel count when known.
pub fn check_format(frame: &GridFrame, path: &Path, solid: Option<u64>) -> Result<()> {
    let ext = extension(path);
    if ext.is_empty() {
        return Err(Error::Invalid(format!(
            "{}: the output has no extension to name its voxel format (use .binvox, .npy, .npz, .nrrd, .ply, \
             .raw, .vdb or .vox, .obj, .stl or .glb for the boundary mesh, or - for .binvox on standard output)",
            path.display()
        )));
    }
    if !FORMATS.contains(&ext.as_str()) {
        return Err(Error::Invalid(format!(
            "{}: unknown voxel format '.{ext}' (use .binvox, .npy, .npz, .nrrd, .ply, .raw, .vdb or .vox, or \
             .obj, .stl or .glb for the boundary mesh)",
            path.display()
        )));
    }
    if ext == "binvox" && frame.cubic_res().is_none() {
        let [x, y, z] = frame.dims;
        let [hx, hy, hz] = frame.voxel_size;
        return Err(Error::Invalid(format!(
            "{}: binvox holds only cubic grids of cubic voxels (one `scale` for the cube, and readers \
             disagree on the axis order of unequal `dim`s), but this grid is {x}×{y}×{z} voxels of \
             {hx}×{hy}×{hz}; use .npy, .nrrd, .raw or .vox, or --res for a cubic grid",
            path.display()
        )));
    }
    if ext == "npz" || ext == "ply" {
        if let Some(n) = solid.filter(|&n| n > SPARSE_MAX_VOXELS) {
            return Err(Error::Invalid(format!(
                "{}: {n} solid voxels are too many for a sparse .{ext} (at most {SPARSE_MAX_VOXELS}, 12 \
                 bytes each within 4 GiB); use a dense format (.npy, .nrrd, .raw, .binvox)",
                path.display()
            )));
        }
    }
    if ext == "vox" {
        if let Some(n) = solid.filter(|&n| n > VOX_MAX_VOXELS) {
            // MAIN's children size is a u32 and every voxel takes 4 bytes.
            return Err(Error::Invalid(format!(
                "{}: {n} solid voxels do not fit a .vox file (at most {VOX_MAX_VOXELS}, 4 bytes each \
                 in one chunk of at most 4 GiB); use .binvox, .npy, .nrrd or .raw",
                path.display()
            )));
        }
    }
    Ok(())
}

/// The format's extension, lower case; standard output (`-`) is written as `.binvox`.
fn extension(path: &Path) -> String {
    if crate::io::is_stdout(path) {
        return "binvox".into();
    }
    path.extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

/// Writes `grid` to `path` in the format its extension names, then its sidecar where the format has one.
/// The grid goes first: a grid write that fails (a full disk) leaves the previous output and its
/// sidecar as they were. (`gregvox batch` counts an output complete only when both files exist.)
pub fn write_grid(grid: &VoxelGrid, path: &Path, opts: &SaveOptions) -> Result<()> {
    let ext = extension(path);
    // A boundary .ply holds faces, not one vertex per solid voxel: the sparse limit is not its.
    let solid = (!(ext == "ply" && opts.ply_boundary)).then(|| grid.count());
    check_format(&grid.frame, path, solid)?;
    let [x, y, z] = grid.frame.dims;
    let layout = match ext.as_str() {
        "npy" if opts.npy_packed => Some(format!(
            "uint8 ({x}, {y}, {}): bits of z, little bit order \
             (np.unpackbits(a, axis=2, bitorder='little')[:, :, :{z}])",
            z.div_ceil(8)
        )),
        "npy" => Some(format!(
            "bool ({x}, {y}, {z}), C order: a[i, j, k] is voxel (i, j, k)"
        )),
        "vox" => Some(format!(
            "MagicaVoxel .vox: models of at most 256 per axis; grid voxel (i,j,k) is world voxel \
             (i - {}, j - {}, k - {}); a model of size s with nTRN translation t holds world voxels \
             t - floor(s/2) + xyz",
            x / 2,
            y / 2,
            z / 2
        )),
        "raw" => Some(format!(
            "little-endian u32; voxel (x, y, z) is word ((y*{x} + x) * {} + z/32), bit z%32",
            z.div_ceil(32)
        )),
        _ => None,
    };
    match ext.as_str() {
        "binvox" => write_atomically(path, |w| w.write_all(&binvox_bytes(grid))),
        "npy" if opts.npy_packed => {
            write_atomically(path, |w| w.write_all(&npy_packed_bytes(grid)))
        }
        "npy" => write_atomically(path, |w| w.write_all(&npy_bytes(grid))),
        "nrrd" => write_atomically(path, |w| w.write_all(&nrrd_bytes(grid))),
        "vox" => write_atomically(path, |w| w.write_all(&vox_bytes(grid))),
        "npz" => {
            let bytes = sparse_npz_bytes(grid)
                .map_err(|e| Error::Invalid(format!("{}: {e}", path.display())))?;
            write_atomically(path, |w| w.write_all(&bytes))
        }
        "ply" if opts.ply_boundary => write_boundary(grid, path),
        "ply" => write_atomically(path, |w| w.write_all(&ply_bytes(grid))),
        "obj" | "stl" | "glb" => write_boundary(grid, path),
        "vdb" => write_atomically(path, |w| w.write_all(&super::vdb::vdb_bytes(grid))),
        "raw" => {
            let g = grid.to_axis(Axis::Z);
            let bytes: &[u8] = bytemuck::cast_slice(&g.words);
            write_atomically(path, |w| w.write_all(bytes))
        }
        _ => unreachable!("check_format accepted only known formats"),
    }?;
    match layout {
        Some(layout) => write_sidecar(grid, path, &layout),
        None => Ok(()),
    }
}

/// The solid's boundary mesh written in the mesh format of `path`'s extension; its placement is the
/// world coordinates of the vertices.
fn write_boundary(grid: &VoxelGrid, path: &Path) -> Result<()> {
    let mesh = super::boundary::boundary_mesh(grid)
        .map_err(|e| Error::Invalid(format!("{}: {e}", path.display())))?;
    crate::mesh::write::write_mesh(path, &mesh)
}

/// The JSON sidecar of a `.npy`/`.raw`/`.vox` output (see the module doc).
pub fn sidecar_json(grid: &VoxelGrid, layout: &str) -> serde_json::Value {
    let f = &grid.frame;
    serde_json::json!({
        "format": "gregvox solid voxels",
        "dims": f.dims,
        "voxel_size": f.voxel_size,
        "origin": f.origin,
        "index_to_world": f.index_to_world(),
        "voxel_centre": "origin + (index + 0.5) * voxel_size = index_to_world · (i, j, k, 1)",
        "layout": layout,
        "solid_voxels": grid.count(),
    })
}

/// The sidecar of output `path`: its whole file name with `.json` appended (`a.vox` → `a.vox.json`), so
/// that outputs differing only in extension never share one.
///
/// ```
/// use gregvox::voxel::export::sidecar_path;
/// assert_eq!(sidecar_path("out/a.vox".as_ref()), std::path::Path::new("out/a.vox.json"));
/// ```
pub fn sidecar_path(path: &Path) -> std::path::PathBuf {
    let mut name = path.as_os_str().to_os_string();
    name.push(".json");
    name.into()
}

/// Writes [`sidecar_path`] beside a `.npy`/`.raw`/`.vox` output.
fn write_sidecar(grid: &VoxelGrid, path: &Path, layout: &str) -> Result<()> {
    let text = serde_json::to_string_pretty(&sidecar_json(grid, layout))
        .map_err(|e| Error::Invalid(e.to_string()))?;
    write_atomically(&sidecar_path(path), |w| w.write_all(text.as_bytes()))
}

/// An NPY (version 1.0) header for `descr` and a 3-d `shape`.
fn npy_header(descr: &str, shape: [usize; 3]) -> Vec<u8> {
    crate::npy::npy_header(descr, &shape)
}

/// NPY (version 1.0): a bool array of shape (X, Y, Z) in C order, `a[i, j, k]` = voxel (i, j, k), so
/// `numpy.load` gives it ready to index.
pub fn npy_bytes(grid: &VoxelGrid) -> Vec<u8> {
    use rayon::prelude::*;
    let [nx, ny, nz] = grid.frame.dims.map(|n| n as usize);
    let header = npy_header("|b1", [nx, ny, nz]);
    let head = header.len();
    // Zeroed by the allocator (fresh pages), not by a sequential fill: the slabs below touch them first.
    let mut out = vec![0u8; head + nx * ny * nz];
    out[..head].copy_from_slice(&header);
    let g = grid.to_axis(Axis::Z);
    // Bits along z: column (u, v) = (x, y); a slab of x is ny·nz bytes of the output.
    out[head..]
        .par_chunks_mut((ny * nz).max(1))
        .enumerate()
        .for_each(|(x, slab)| {
            for (y, row) in slab.chunks_mut(nz.max(1)).enumerate() {
                expand_bits(g.column(x as u32, y as u32), row);
            }
        });
    out
}

/// One byte (0 or 1) per bit of the little-endian byte: `BYTE_BITS[b]` read as little-endian bytes.
static BYTE_BITS: [u64; 256] = {
    let mut t = [0u64; 256];
    let mut b = 0;
    while b < 256 {
        let mut i = 0;
        while i < 8 {
            t[b] |= (((b >> i) & 1) as u64) << (8 * i);
            i += 1;
        }
        b += 1;
    }
    t
};

/// Writes the first `out.len()` bits of `words` (low bit first) as bytes 0/1: a word's 32 bytes are four
/// table lookups, no per-bit reads.
fn expand_bits(words: &[u32], out: &mut [u8]) {
    let full = out.len() / 32;
    for (dst, &w) in out.chunks_exact_mut(32).zip(words) {
        let b = w.to_le_bytes();
        dst[0..8].copy_from_slice(&BYTE_BITS[b[0] as usize].to_le_bytes());
        dst[8..16].copy_from_slice(&BYTE_BITS[b[1] as usize].to_le_bytes());
        dst[16..24].copy_from_slice(&BYTE_BITS[b[2] as usize].to_le_bytes());
        dst[24..32].copy_from_slice(&BYTE_BITS[b[3] as usize].to_le_bytes());
    }
    let rest = &mut out[full * 32..];
    if !rest.is_empty() {
        let w = words[full];
        for (i, d) in rest.iter_mut().enumerate() {
            *d = (w >> i & 1) as u8;
        }
    }
}

/// NPY (version 1.0): uint8 array of shape (X, Y, ceil(Z/8)) in C order, the packed bits of z for each
/// (x, y) (`np.unpackbits(a, axis=2, bitorder='little')[:, :, :Z]` gives the (x, y, z) occupancy).
pub fn npy_packed_bytes(grid: &VoxelGrid) -> Vec<u8> {
    let [nx, ny, nz] = grid.frame.dims;
    let zb = nz.div_ceil(8) as usize;
    let mut out = npy_header("|u1", [nx as usize, ny as usize, zb]);
    let g = grid.to_axis(Axis::Z);
    for x in 0..nx {
        for y in 0..ny {
            let bytes: &[u8] = bytemuck::cast_slice(g.column(x, y));
            out.extend_from_slice(&bytes[..zb]);
        }
    }
    out
}

/// NRRD: uint8 (0/1), sizes X Y Z with x fastest, raw encoding, per-axis voxel sizes as `space directions`
/// and the centre of voxel (0,0,0) as `space origin`.
pub fn nrrd_bytes(grid: &VoxelGrid) -> Vec<u8> {
    let f = &grid.frame;
    let [nx, ny, nz] = f.dims;
    let [hx, hy, hz] = f.voxel_size;
    let c = f.centre(0, 0, 0);
    let out = format!(
        "NRRD0004\ntype: uint8\ndimension: 3\nsizes: {nx} {ny} {nz}\nencoding: raw\nspace dimension: 3\n\
         space directions: ({hx},0,0) (0,{hy},0) (0,0,{hz})\nspace origin: ({},{},{})\n\n",
        c[0], c[1], c[2]
    )
    .into_bytes();
    let g = grid.to_axis(Axis::X);
    // Bit axis X: columns (u, v) = (y, z), stored z-major: the file's order, x fastest in each column.
    use rayon::prelude::*;
    let (nx, w) = (nx as usize, g.frame.words_per_column(Axis::X) as usize);
    let header = out;
    let head = header.len();
    let mut out = vec![0u8; head + nx * ny as usize * nz as usize];
    out[..head].copy_from_slice(&header);
    out[head..]
        .par_chunks_mut((nx * ny as usize).max(1))
        .zip(g.words.par_chunks((w * ny as usize).max(1)))
        .for_each(|(slab, words)| {
            for (row, col) in slab.chunks_mut(nx.max(1)).zip(words.chunks(w.max(1))) {
                expand_bits(col, row);
            }
        });
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
/// covers world voxels `t − ⌊s/2⌋ … t − ⌊s/2⌋ + s − 1`), under one `nGRP`. World voxel = grid voxel − ⌊dims/2⌋ on
/// every axis, which keeps R ≤ 2048 inside MagicaVoxel's ±1000 world. Axes are kept as they are (x, y, z; z
/// is up in MagicaVoxel). Models with no voxel are skipped unless the whole grid is empty. Non-cubic grids are
/// cut the same way on each axis (world voxel = grid voxel − ⌊dims_a/2⌋).
///
/// ```
/// use gregvox::voxel::{export::vox_bytes, grid::{Axis, GridFrame, VoxelGrid}};
/// let mut g = VoxelGrid::empty(GridFrame::cubic(2, [0.0; 3], 1.0), Axis::Z);
/// g.set(1, 0, 1, true);
/// let b = vox_bytes(&g);
/// assert!(b.starts_with(b"VOX \x96\x00\x00\x00MAIN"));
/// let xyzi = b.windows(4).position(|w| w == b"XYZI").unwrap();
/// // one voxel at (1, 0, 1) with colour index 1
/// assert_eq!(&b[xyzi + 12..xyzi + 20], &[1, 0, 0, 0, 1, 0, 1, 1]);
/// ```
pub fn vox_bytes(grid: &VoxelGrid) -> Vec<u8> {
    let f = &grid.frame;
    let dims = f.dims;
    let g = grid.to_axis(Axis::Z);
    let n = dims.map(|d| d.div_ceil(VOX_MODEL_MAX));
    let half = dims.map(|d| (d / 2) as i64);
    let mut models: Vec<([u32; 3], [u32; 3], Vec<u8>)> = Vec::new();
    for cx in 0..n[0] {
        for cy in 0..n[1] {
            for cz in 0..n[2] {
                let lo = [cx, cy, cz].map(|c| c * VOX_MODEL_MAX);
                let size: [u32; 3] = std::array::from_fn(|a| (dims[a] - lo[a]).min(VOX_MODEL_MAX));
                let mut xyzi = Vec::new();
                for y in lo[1]..lo[1] + size[1] {
                    for x in lo[0]..lo[0] + size[0] {
                        // Bits along z: column (u, v) = (x, y).
                        let col = g.column(x, y);
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
        let size = dims.map(|d| d.min(VOX_MODEL_MAX));
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
            .map(|a| (lo[a] as i64 + (size[a] / 2) as i64 - half[a]).to_string())
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

/// The solid voxels' indices, sorted (x slowest, then y, z fastest): what the sparse outputs list. Slabs of x
/// run in parallel, set bits found word by word.
pub fn solid_coords(grid: &VoxelGrid) -> Vec<[u32; 3]> {
    use rayon::prelude::*;
    let g = grid.to_axis(Axis::Z);
    let [nx, ny, _] = g.frame.dims;
    let w = g.frame.words_per_column(Axis::Z) as usize;
    let slabs: Vec<Vec<[u32; 3]>> = (0..nx)
        .into_par_iter()
        .map(|x| {
            let mut out = Vec::new();
            for y in 0..ny {
                // Bit axis Z: column (u, v) = (x, y).
                for (wi, &word) in g.column(x, y).iter().enumerate().take(w) {
                    let mut bits = word;
                    while bits != 0 {
                        let b = bits.trailing_zeros();
                        bits &= bits - 1;
                        out.push([x, y, wi as u32 * 32 + b]);
                    }
                }
            }
            out
        })
        .collect();
    slabs.concat()
}

/// The sparse `.npz` of `grid` (the MinkowskiEngine / spconv / TRELLIS input): `coords` (int32, N × 3, the
/// solid voxels' (i, j, k), sorted), `origin` and `voxel_size` (float64, 3: voxel (i, j, k) has its centre
/// at origin + (index + ½)·voxel_size), `dims` (int32, 3).
pub fn sparse_npz_bytes(grid: &VoxelGrid) -> std::result::Result<Vec<u8>, String> {
    use crate::npy::Array;
    let coords = solid_coords(grid);
    let f = &grid.frame;
    let i32s = |v: &[u32], shape: Vec<usize>| Array {
        descr: "<i4",
        shape,
        data: v.iter().flat_map(|&x| (x as i32).to_le_bytes()).collect(),
    };
    let flat: Vec<u32> = coords.iter().flatten().copied().collect();
    crate::npy::npz_bytes(&[
        ("coords", i32s(&flat, vec![coords.len(), 3])),
        ("origin", Array::f64s(&f.origin)),
        ("voxel_size", Array::f64s(&f.voxel_size)),
        ("dims", i32s(&f.dims, vec![3])),
    ])
}

/// A binary little-endian PLY of the solid voxels' centres (float32 x, y, z vertices, no faces), in the
/// order of [`solid_coords`].
pub fn ply_bytes(grid: &VoxelGrid) -> Vec<u8> {
    let coords = solid_coords(grid);
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\ncomment gregvox voxel centres\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\nend_header\n",
        coords.len()
    )
    .into_bytes();
    out.reserve(coords.len() * 12);
    for c in coords {
        let p = grid.frame.centre(c[0], c[1], c[2]);
        for x in p {
            out.extend_from_slice(&(x as f32).to_le_bytes());
        }
    }
    out
}
