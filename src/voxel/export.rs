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
//! transposes (`VoxelGrid::to_axis`), `.npy`/`.nrrd` expand a word's bits to bytes by table lookups; slabs
//! of the slowest axis run in parallel. binvox and `.vox` size their output first and fill it in place,
//! in parallel, into one buffer allocated once: binvox counts each chunk's runs from the word's
//! transitions (`m ^ (m << 1 | previous bit)`: popcount, no per-run work), joins the chunks' end runs,
//! then writes the runs of a mixed word branch-free (transition positions by byte-table lookups, 64
//! bytes of (value, length) pairs stored at once) while whole words of one value only lengthen a run;
//! `.vox` counts each model row's solid voxels by popcounts, then writes their 4-byte records found by
//! `trailing_zeros` (32 at once for a full word). Memory is the output's bytes plus one copy of the packed
//! grid. The worst case is binvox on noise (a run every voxel or two: two bytes per run, output up to
//! twice the voxel count): at 1024³ hashed noise (970 MB of runs) it went from 1844 ms to 893–1107 ms
//! (1.2–0.97 G voxels/s in two runs on this shared machine; about a third of it the transpose and a third
//! the output's fresh pages, which huge pages would cut), and `.vox`
//! at 256³ from 68/101 ms (ball/noise) to 7/11 ms, 2 threads, `gregvox bench --suite writers`, which
//! measures a 1024³ ball and 1024³ hashed noise in every format.
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
    use rayon::prelude::*;
    let f = &grid.frame;
    let [nx, ny, nz] = f.dims;
    let side = f.voxel_size[0] * nx as f64;
    let header = format!(
        "#binvox 1\ndim {nx} {ny} {nz}\ntranslate {} {} {}\nscale {}\ndata\n",
        f.origin[0], f.origin[1], f.origin[2], side
    )
    .into_bytes();
    // binvox runs y fastest: lay the bits along y so each (x, z) column streams in order (bit axis Y's
    // columns are (u, v) = (z, x), stored x-major: the file's order). The stream is cut into chunks of
    // whole columns; each chunk's runs are counted in parallel (first pass, no writes), the chunks' first
    // and last runs are joined with the neighbours' here, and the runs between are written in parallel
    // straight into their place in the one output buffer (second pass): memory is the output's.
    let g = grid.to_axis(Axis::Y);
    let w = g.frame.words_per_column(Axis::Y) as usize;
    let cols = (BINVOX_CHUNK_WORDS / w).max(1);
    let chunks: Vec<&[u32]> = g.words.chunks(cols * w).collect();
    let spans: Vec<RunSpan> = chunks.par_iter().map(|c| count_runs(c, w, ny)).collect();
    // The whole stream's maximal runs in order: a chunk's first run (joined with what came before), the
    // chunk's encoded interior, its last run held open.
    let mut pieces: Vec<Piece> = Vec::new();
    let mut carry: Option<(u8, u64)> = None;
    for (i, s) in spans.iter().enumerate() {
        let first = s.first;
        match (carry, s.last) {
            // The chunk is one run: it only lengthens or replaces the carry.
            (Some(c), None) if c.0 == first.0 => carry = Some((c.0, c.1 + first.1)),
            (c, None) => {
                if let Some(c) = c {
                    pieces.push(Piece::Run(c));
                }
                carry = Some(first);
            }
            (c, Some(last)) => {
                match c {
                    Some(c) if c.0 == first.0 => pieces.push(Piece::Run((c.0, c.1 + first.1))),
                    Some(c) => {
                        pieces.push(Piece::Run(c));
                        pieces.push(Piece::Run(first));
                    }
                    None => pieces.push(Piece::Run(first)),
                }
                pieces.push(Piece::Interior(i));
                carry = Some(last);
            }
        }
    }
    if let Some(c) = carry {
        pieces.push(Piece::Run(c));
    }
    let size = |p: &Piece| match *p {
        Piece::Run((_, n)) => 2 * n.div_ceil(255) as usize,
        Piece::Interior(i) => spans[i].interior as usize,
    };
    let total = header.len() + pieces.iter().map(size).sum::<usize>();
    // Zeroed by the allocator (fresh pages): the parallel pass below touches most of them first.
    let mut out = vec![0u8; total];
    out[..header.len()].copy_from_slice(&header);
    let mut rest = &mut out[header.len()..];
    let mut jobs: Vec<(usize, &mut [u8])> = Vec::new();
    for p in &pieces {
        let (here, tail) = std::mem::take(&mut rest).split_at_mut(size(p));
        match *p {
            Piece::Run(r) => {
                put_run(here, 0, r);
            }
            Piece::Interior(i) => jobs.push((i, here)),
        }
        rest = tail;
    }
    jobs.into_par_iter().for_each(|(i, dst)| {
        let n = write_runs(chunks[i], w, ny, dst);
        debug_assert_eq!(n, dst.len());
    });
    out
}

/// Words of the grid (bits along y) per chunk of `binvox_bytes`: whole columns, about 2 M voxels.
const BINVOX_CHUNK_WORDS: usize = 1 << 16;

/// One piece of the binvox data: a run (split in pairs of at most 255), or chunk `i`'s interior runs.
enum Piece {
    Run((u8, u64)),
    Interior(usize),
}

/// A chunk's runs, counted: its first run (`last` is `None` when the chunk is that one run), the bytes of
/// the runs between the first and the last, and its last run (a neighbouring chunk may continue both).
struct RunSpan {
    first: (u8, u64),
    interior: u64,
    last: Option<(u8, u64)>,
}

/// The bits of word `i` of a column of `len` bits: `(bits, mask)`.
#[inline]
fn word_bits(i: usize, len: u32) -> (u32, u32) {
    let bits = (len - 32 * i as u32).min(32);
    (
        bits,
        if bits == 32 {
            u32::MAX
        } else {
            (1u32 << bits) - 1
        },
    )
}

/// Counts the runs of `words` (columns of `w` words, `len` bits each, streamed in order) without writing
/// them: a run starts where a bit differs from the one before (`m ^ (m << 1 | previous bit)`), so a word
/// costs a few bit operations however many runs it holds; runs inside one word are shorter than 32 and
/// take one pair each.
fn count_runs(words: &[u32], w: usize, len: u32) -> RunSpan {
    #[cfg(target_arch = "x86_64")]
    if has_bit_ops() {
        // SAFETY: the CPU has the instructions `count_runs_x86` is compiled for.
        return unsafe { count_runs_x86(words, w, len) };
    }
    count_runs_in(words, w, len)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "bmi1,lzcnt,popcnt")]
fn count_runs_x86(words: &[u32], w: usize, len: u32) -> RunSpan {
    count_runs_in(words, w, len)
}

#[inline(always)]
fn count_runs_in(words: &[u32], w: usize, len: u32) -> RunSpan {
    let (last_bits, last_mask) = word_bits(w - 1, len);
    let mut first: Option<(u8, u64)> = None;
    let (mut val, mut run) = ((words[0] & 1) as u8, 0u64);
    let mut interior = 0u64;
    for col in words.chunks_exact(w) {
        for (i, &word) in col.iter().enumerate() {
            let (bits, mask) = if i + 1 == w {
                (last_bits, last_mask)
            } else {
                (32, u32::MAX)
            };
            let m = word & mask;
            let t = (m ^ (m << 1 | val as u32)) & mask;
            if t == 0 {
                run += bits as u64;
                continue;
            }
            let closed = (val, run + t.trailing_zeros() as u64);
            if first.is_none() {
                first = Some(closed);
            } else {
                interior += 2 * closed.1.div_ceil(255);
            }
            interior += 2 * (t.count_ones() as u64 - 1);
            val = (m >> (bits - 1) & 1) as u8;
            run = (bits - (31 - t.leading_zeros())) as u64;
        }
    }
    match first {
        None => RunSpan {
            first: (val, run),
            interior: 0,
            last: None,
        },
        Some(first) => RunSpan {
            first,
            interior,
            last: Some((val, run)),
        },
    }
}

/// Writes the runs of `words` that [`count_runs`] counts as interior (all but the first and the last)
/// into `out` from its start; returns the bytes written. Words of one value only lengthen the open run;
/// a mixed word closes it (split by 255 if long) and writes the runs inside it without a branch per run
/// (below), or, within 64 bytes of the end of `out`, transition by transition (`trailing_zeros`).
/// Compiled for the baseline CPU: BMI1 made this loop slower here (measured), unlike [`count_runs`].
fn write_runs(words: &[u32], w: usize, len: u32, out: &mut [u8]) -> usize {
    let (last_bits, last_mask) = word_bits(w - 1, len);
    let mut seen_first = false;
    let (mut val, mut run) = ((words[0] & 1) as u8, 0u64);
    let mut o = 0usize;
    for col in words.chunks_exact(w) {
        for (i, &word) in col.iter().enumerate() {
            let (bits, mask) = if i + 1 == w {
                (last_bits, last_mask)
            } else {
                (32, u32::MAX)
            };
            let m = word & mask;
            let mut t = (m ^ (m << 1 | val as u32)) & mask;
            if t == 0 {
                run += bits as u64;
                continue;
            }
            let mut start = t.trailing_zeros();
            if seen_first {
                o = put_run(out, o, (val, run + start as u64));
            } else {
                seen_first = true;
            }
            let v = val ^ 1;
            val = (m >> (bits - 1) & 1) as u8;
            if o + 64 <= out.len() {
                // The runs between the word's transitions, branch-free: the transitions' positions by
                // byte-table lookups, their differences and the alternating values interleaved as
                // fixed-size arrays, 64 bytes stored and the cursor moved by the runs there were (the
                // bytes past them are overwritten by what follows).
                let mut pos = [0u8; 40];
                let mut n = 0;
                for (j, b) in t.to_le_bytes().into_iter().enumerate() {
                    let p = BIT_POS[b as usize] + 0x0808_0808_0808_0808 * j as u64;
                    pos[n..n + 8].copy_from_slice(&p.to_le_bytes());
                    n += b.count_ones() as usize;
                }
                let mut pairs = [0u16; 32];
                let ends = pos[1..33].iter().zip(&pos[..32]);
                for ((pair, (&end, &start)), &value) in
                    pairs.iter_mut().zip(ends).zip(&ALTERNATE[v as usize])
                {
                    *pair = (end.wrapping_sub(start) as u16) << 8 | value;
                }
                out[o..o + 64].copy_from_slice(bytemuck::cast_slice(&pairs));
                o += 2 * (n - 1);
                run = (bits - pos[n - 1] as u32) as u64;
                continue;
            }
            t &= t - 1;
            let mut v = v;
            while t != 0 {
                let p = t.trailing_zeros();
                out[o..o + 2]
                    .copy_from_slice(&(v as u16 | ((p - start) as u16) << 8).to_le_bytes());
                o += 2;
                v ^= 1;
                start = p;
                t &= t - 1;
            }
            run = (bits - start) as u64;
        }
    }
    o
}

/// Whether the CPU has single instructions for `trailing_zeros`, `leading_zeros` and `count_ones` (BMI1,
/// LZCNT, POPCNT): the baseline x86-64 build emulates `count_ones` in a dozen instructions and uses BSF,
/// slow on AMD cores, for `trailing_zeros`.
#[cfg(target_arch = "x86_64")]
fn has_bit_ops() -> bool {
    std::arch::is_x86_feature_detected!("bmi1")
        && std::arch::is_x86_feature_detected!("lzcnt")
        && std::arch::is_x86_feature_detected!("popcnt")
}

/// The positions of the set bits of a byte, low first, one per byte of the `u64` (little-endian).
static BIT_POS: [u64; 256] = {
    let mut t = [0u64; 256];
    let mut b = 0;
    while b < 256 {
        let (mut i, mut n) = (0, 0);
        while i < 8 {
            if b >> i & 1 == 1 {
                t[b] |= (i as u64) << (8 * n);
                n += 1;
            }
            i += 1;
        }
        b += 1;
    }
    t
};

/// The values of consecutive runs, as the low byte of (value, count) pairs: 0, 1, 0, … and 1, 0, 1, ….
static ALTERNATE: [[u16; 32]; 2] = {
    let mut t = [[0u16; 32]; 2];
    let mut i = 0;
    while i < 32 {
        t[0][i] = (i & 1) as u16;
        t[1][i] = 1 - (i & 1) as u16;
        i += 1;
    }
    t
};

/// Writes run (value, n) as (value, count ≤ 255) pairs into `out` at `o`; returns the position after.
#[inline]
fn put_run(out: &mut [u8], mut o: usize, (value, mut n): (u8, u64)) -> usize {
    if n <= 255 {
        out[o..o + 2].copy_from_slice(&[value, n as u8]);
        return o + 2;
    }
    while n > 0 {
        let take = n.min(255);
        out[o..o + 2].copy_from_slice(&[value, take as u8]);
        o += 2;
        n -= take;
    }
    o
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
    use rayon::prelude::*;
    let f = &grid.frame;
    let dims = f.dims;
    let g = grid.to_axis(Axis::Z);
    let n = dims.map(|d| d.div_ceil(VOX_MODEL_MAX));
    let half = dims.map(|d| (d / 2) as i64);
    let mut cut: Vec<([u32; 3], [u32; 3])> = Vec::new();
    for cx in 0..n[0] {
        for cy in 0..n[1] {
            for cz in 0..n[2] {
                let lo = [cx, cy, cz].map(|c| c * VOX_MODEL_MAX);
                let size: [u32; 3] = std::array::from_fn(|a| (dims[a] - lo[a]).min(VOX_MODEL_MAX));
                cut.push((lo, size));
            }
        }
    }
    // A model's voxels are listed y slowest, then x, z fastest: one row per (model, y), counted in
    // parallel by popcounts, then written in parallel into their place in the one output buffer.
    let rows: Vec<(usize, u32)> = cut
        .iter()
        .enumerate()
        .flat_map(|(m, (lo, size))| (lo[1]..lo[1] + size[1]).map(move |y| (m, y)))
        .collect();
    let counts: Vec<usize> = rows
        .par_iter()
        .map(|&(m, y)| vox_row(&g, cut[m], y, None))
        .collect();
    let mut per_model = vec![0usize; cut.len()];
    for (&(m, _), &c) in rows.iter().zip(&counts) {
        per_model[m] += c;
    }
    // Models with no voxel are skipped unless the whole grid is empty.
    // (lo, size, voxels, its first row)
    let mut models: Vec<([u32; 3], [u32; 3], usize, usize)> = Vec::new();
    let mut first_row = 0;
    for (&(lo, size), &c) in cut.iter().zip(&per_model) {
        if c > 0 {
            models.push((lo, size, c, first_row));
        }
        first_row += size[1] as usize;
    }
    if models.is_empty() {
        models.push(([0; 3], dims.map(|d| d.min(VOX_MODEL_MAX)), 0, 0));
    }
    // Scene graph: 0 = root nTRN → 1 = nGRP → (2 + 2m) nTRN → (3 + 2m) nSHP(model m).
    let mut tail = Vec::new();
    let mut c = Vec::new();
    c.extend_from_slice(&0u32.to_le_bytes());
    vox_dict(&mut c, &[]);
    c.extend_from_slice(&1u32.to_le_bytes());
    c.extend_from_slice(&(-1i32).to_le_bytes());
    c.extend_from_slice(&0u32.to_le_bytes()); // layer
    c.extend_from_slice(&1u32.to_le_bytes()); // frames
    vox_dict(&mut c, &[]);
    vox_chunk(&mut tail, b"nTRN", &c, &[]);
    let mut c = Vec::new();
    c.extend_from_slice(&1u32.to_le_bytes());
    vox_dict(&mut c, &[]);
    c.extend_from_slice(&(models.len() as u32).to_le_bytes());
    for m in 0..models.len() as u32 {
        c.extend_from_slice(&(2 + 2 * m).to_le_bytes());
    }
    vox_chunk(&mut tail, b"nGRP", &c, &[]);
    for (m, (lo, size, _, _)) in models.iter().enumerate() {
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
        vox_chunk(&mut tail, b"nTRN", &c, &[]);
        let mut c = Vec::new();
        c.extend_from_slice(&(3 + 2 * m).to_le_bytes());
        vox_dict(&mut c, &[]);
        c.extend_from_slice(&1u32.to_le_bytes());
        c.extend_from_slice(&m.to_le_bytes());
        vox_dict(&mut c, &[]);
        vox_chunk(&mut tail, b"nSHP", &c, &[]);
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
    vox_chunk(&mut tail, b"RGBA", &rgba, &[]);
    // Each model: SIZE (12 + 12 bytes), XYZI (12 + 4 + 4 per voxel).
    let children = models.iter().map(|m| 40 + 4 * m.2).sum::<usize>() + tail.len();
    // Zeroed by the allocator (fresh pages): the parallel pass below touches most of them first.
    let mut out = vec![0u8; 20 + children];
    let chunk_head = |dst: &mut [u8], id: &[u8; 4], content: usize, children: usize| {
        dst[..4].copy_from_slice(id);
        dst[4..8].copy_from_slice(&(content as u32).to_le_bytes());
        dst[8..12].copy_from_slice(&(children as u32).to_le_bytes());
    };
    out[..4].copy_from_slice(b"VOX ");
    out[4..8].copy_from_slice(&150u32.to_le_bytes());
    chunk_head(&mut out[8..20], b"MAIN", 0, children);
    let mut rest = &mut out[20..];
    let mut jobs: Vec<((usize, u32), &mut [u8])> = Vec::new();
    for &(_, size, count, first_row) in &models {
        let (head, r) = std::mem::take(&mut rest).split_at_mut(40);
        chunk_head(&mut head[..12], b"SIZE", 12, 0);
        for a in 0..3 {
            head[12 + 4 * a..16 + 4 * a].copy_from_slice(&size[a].to_le_bytes());
        }
        chunk_head(&mut head[24..36], b"XYZI", 4 + 4 * count, 0);
        head[36..40].copy_from_slice(&(count as u32).to_le_bytes());
        rest = r;
        if count == 0 {
            continue;
        }
        for row in first_row..first_row + size[1] as usize {
            let (dst, r) = std::mem::take(&mut rest).split_at_mut(4 * counts[row]);
            jobs.push((rows[row], dst));
            rest = r;
        }
    }
    rest.copy_from_slice(&tail);
    jobs.into_par_iter().for_each(|((m, y), dst)| {
        vox_row(&g, cut[m], y, Some(dst));
    });
    out
}

/// The solid voxels of row y of model `(lo, size)` (bits along z): their count, and with `out` their
/// 4-byte records (x, y, z, colour 1; model coordinates) written in order, x then z, found word by word
/// (`trailing_zeros`, clear the lowest bit).
fn vox_row(
    g: &VoxelGrid,
    (lo, size): ([u32; 3], [u32; 3]),
    y: u32,
    out: Option<&mut [u8]>,
) -> usize {
    let (z0, z1) = (lo[2], lo[2] + size[2]);
    let (w0, w1) = (z0 as usize / 32, z1.div_ceil(32) as usize);
    // Model edges are multiples of 32 (256) except at the grid's end: only the last word is cut.
    let last_mask = if z1 % 32 == 0 {
        u32::MAX
    } else {
        (1u32 << (z1 % 32)) - 1
    };
    let word = |col: &[u32], wi: usize| {
        if wi + 1 == w1 {
            col[wi] & last_mask
        } else {
            col[wi]
        }
    };
    let xs = lo[0]..lo[0] + size[0];
    let Some(out) = out else {
        return xs
            .map(|x| {
                let col = g.column(x, y);
                (w0..w1)
                    .map(|wi| word(col, wi).count_ones() as usize)
                    .sum::<usize>()
            })
            .sum();
    };
    let mut o = 0;
    let yb = (y - lo[1]) << 8 | 1 << 24;
    for x in xs {
        let col = g.column(x, y);
        let xy = (x - lo[0]) | yb;
        for wi in w0..w1 {
            let mut bits = word(col, wi);
            let zb = ((wi * 32) as u32 - z0) << 16 | xy;
            if bits == u32::MAX {
                for (k, rec) in out[o..o + 128].chunks_exact_mut(4).enumerate() {
                    rec.copy_from_slice(&(zb + ((k as u32) << 16)).to_le_bytes());
                }
                o += 128;
                continue;
            }
            while bits != 0 {
                let z = bits.trailing_zeros();
                out[o..o + 4].copy_from_slice(&(zb + (z << 16)).to_le_bytes());
                o += 4;
                bits &= bits - 1;
            }
        }
    }
    o / 4
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

#[cfg(test)]
mod fast_encoders {
    //! The word-based binvox and `.vox` encoders against the straightforward ones they replaced (kept here
    //! as the reference): the bytes must be identical on every grid.
    use super::*;

    /// The binvox data (after the header) as the old encoder wrote it: maximal runs of the file's order
    /// (x slowest, z, y fastest), each as (value, 255) pairs and a remainder.
    fn binvox_reference(grid: &VoxelGrid) -> Vec<u8> {
        let [n, _, _] = grid.frame.dims;
        let f = &grid.frame;
        let mut out = format!(
            "#binvox 1\ndim {n} {n} {n}\ntranslate {} {} {}\nscale {}\ndata\n",
            f.origin[0],
            f.origin[1],
            f.origin[2],
            f.voxel_size[0] * n as f64
        )
        .into_bytes();
        let [nx, ny, nz] = f.dims;
        let mut run: Option<(u8, u64)> = None;
        for x in 0..nx {
            for z in 0..nz {
                for y in 0..ny {
                    let v = grid.get(x, y, z) as u8;
                    run = match run {
                        Some((rv, k)) if rv == v => Some((rv, k + 1)),
                        Some(r) => {
                            emit_run(&mut out, r);
                            Some((v, 1))
                        }
                        None => Some((v, 1)),
                    };
                }
            }
        }
        emit_run(&mut out, run.unwrap());
        out
    }

    // ---- The encoders as they were before the two-pass, preallocated ones (issue 35), verbatim. ----

    fn old_binvox_bytes(grid: &VoxelGrid) -> Vec<u8> {
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

    // A stretch of binvox runs: the first run and the last run held open (a neighbouring stretch may continue
    // them), the ones between already encoded.
    #[derive(Default)]
    struct RunBytes {
        first: Option<(u8, u64)>,
        bytes: Vec<u8>,
        // The open run after `first`, if any.
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

    // Appends run (value, n) as (value, count ≤ 255) pairs.
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

    // Appends the runs of one column of `len` bits. Whole words of one value extend a run by 32 at once and
    // mixed words go run by run (trailing zeros and ones), so the cost is per word and per run, never per
    // voxel.
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

    fn old_vox_bytes(grid: &VoxelGrid) -> Vec<u8> {
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
                    let size: [u32; 3] =
                        std::array::from_fn(|a| (dims[a] - lo[a]).min(VOX_MODEL_MAX));
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

    /// A solid ball filling the inscribed sphere (bits along z), as the writers bench makes it.
    fn ball(res: u32) -> VoxelGrid {
        let mut g = VoxelGrid::empty(GridFrame::cubic(res, [0.0; 3], 1.0), Axis::Z);
        let c = res as f64 / 2.0;
        let r2 = (0.45 * res as f64).powi(2);
        for x in 0..res {
            for y in 0..res {
                for z in 0..res {
                    let d = [x, y, z].map(|i| (i as f64 + 0.5 - c).powi(2));
                    if d[0] + d[1] + d[2] < r2 {
                        g.set(x, y, z, true);
                    }
                }
            }
        }
        g
    }

    /// Hashed noise, about one voxel in three solid, bits along z (the writers bench's).
    fn noise(dims: [u32; 3]) -> VoxelGrid {
        let frame = GridFrame {
            dims,
            origin: [0.0; 3],
            voxel_size: [1.0 / dims[0] as f64; 3],
        };
        let mut g = VoxelGrid::empty(frame, Axis::Z);
        for (i, w) in g.words.iter_mut().enumerate() {
            let mut x = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x2545_F491_4F6C_DD1D;
            x ^= x >> 29;
            x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
            x ^= x >> 32;
            let (a, b, c) = (x as u32, (x >> 32) as u32, (x as u32).rotate_left(13));
            *w = (a & b) | (c & a.rotate_left(7) & b.rotate_left(19));
        }
        let rem = dims[2] % 32;
        if rem != 0 {
            let w = g.frame.words_per_column(Axis::Z) as usize;
            for col in g.words.chunks_mut(w) {
                col[w - 1] &= (1u32 << rem) - 1;
            }
        }
        g
    }

    /// Grids of every kind: random densities (long runs and a run every voxel), sizes off multiples of
    /// 32, empty, full, a ball, one voxel, thin columns, runs longer than 255 crossing columns and
    /// chunks, every bit axis.
    fn grids() -> Vec<VoxelGrid> {
        let mut v = Vec::new();
        let mut seed = 1;
        for dims in [
            [1, 1, 1],
            [2, 2, 2],
            [1, 1, 70],
            [1, 70, 1],
            [70, 1, 1],
            [5, 33, 31],
            [33, 33, 33],
            [64, 64, 64],
            [37, 300, 45],
            [300, 20, 17],
        ] {
            for density in [0.0, 1e-4, 0.01, 0.3, 0.5, 0.9, 0.9999, 1.0] {
                for axis in Axis::ALL {
                    seed += 1;
                    v.push(random_grid(dims, density, seed, axis));
                }
            }
        }
        for res in [1, 2, 31, 32, 33, 63, 100, 257] {
            v.push(ball(res));
            v.push(noise([res; 3]));
            let mut full = VoxelGrid::empty(GridFrame::cubic(res, [0.0; 3], 1.0), Axis::Y);
            for x in 0..res {
                for y in 0..res {
                    for z in 0..res {
                        full.set(x, y, z, true);
                    }
                }
            }
            v.push(full);
        }
        // Long runs across chunk boundaries: a few isolated voxels in a grid of several chunks.
        let mut sparse = VoxelGrid::empty(GridFrame::cubic(160, [0.0; 3], 1.0), Axis::Z);
        for (x, y, z) in [(0, 0, 0), (3, 159, 7), (80, 80, 80), (159, 159, 159)] {
            sparse.set(x, y, z, true);
        }
        v.push(sparse);
        v.push(noise([300, 260, 520]));
        v
    }

    #[test]
    fn binvox_bytes_unchanged() {
        for g in grids() {
            if g.frame.cubic_res().is_none() {
                // binvox writes only cubic grids; the encoders still agree on the others.
                assert_eq!(
                    binvox_bytes(&g),
                    old_binvox_bytes(&g),
                    "dims {:?}",
                    g.frame.dims
                );
                continue;
            }
            let new = binvox_bytes(&g);
            assert_eq!(new, old_binvox_bytes(&g), "dims {:?}", g.frame.dims);
            if g.frame.voxel_count() <= 1 << 20 {
                assert_eq!(new, binvox_reference(&g), "dims {:?}", g.frame.dims);
            }
        }
    }

    #[test]
    fn vox_bytes_unchanged() {
        for g in grids() {
            assert_eq!(vox_bytes(&g), old_vox_bytes(&g), "dims {:?}", g.frame.dims);
        }
    }

    /// A grid of `dims` with about `density` of its voxels solid (xorshift, seeded), bits along `axis`.
    fn random_grid(dims: [u32; 3], density: f64, seed: u64, axis: Axis) -> VoxelGrid {
        let frame = GridFrame {
            dims,
            origin: [0.5, -1.0, 2.0],
            voxel_size: [0.25; 3],
        };
        let mut g = VoxelGrid::empty(frame, axis);
        let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        for x in 0..dims[0] {
            for y in 0..dims[1] {
                for z in 0..dims[2] {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    if ((s >> 11) as f64 / (1u64 << 53) as f64) < density {
                        g.set(x, y, z, true);
                    }
                }
            }
        }
        g
    }
}
