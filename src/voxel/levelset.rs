//! A narrow-band signed distance level set on a voxel grid, in OpenVDB's sparse layout: 8³ leaves holding
//! the band's distances, uniform regions as tiles of ±background.
//!
//! Definitions: the *band* is every voxel within `half_width` voxels (per axis, Chebyshev) of a voxel the
//! surface touches (`voxel::surface`), so every voxel whose centre lies closer than `half_width` voxel sizes
//! to the surface is in it. A band voxel is *active* when its distance is below the background,
//! `half_width` × the largest voxel size; its value is the exact distance (rounded to f32) negated where the
//! grid's voxel is solid, so the level set's sign is the voxelization's decision voxel for voxel (the
//! generalized winding number on open meshes). Every other voxel holds −background where solid and
//! +background where empty (OpenVDB's convention for inactive level-set values). Under the winding number
//! the solid's boundary can leave the surface (across a hole, w passes ½ in empty space); there the sign
//! changes between inactive values, which the leaves keep: a region is a tile only when its voxels are
//! all solid or all empty and none is active.
//!
//! Cost: the band by word operations (the dilation is `half_width` shifts per axis), distances for the
//! band voxels only (a parallel query: O(band · log T)), leaves by 64 column bytes each; memory: the band's
//! points and 2 KiB per leaf.
use super::grid::{Axis, GridFrame, VoxelGrid};
use super::vdb::leaf_mask;
use rayon::prelude::*;

/// The default half-width in voxels (OpenVDB's `LEVEL_SET_HALF_WIDTH`).
pub const HALF_WIDTH: u32 = 3;

/// One 8³ leaf: its origin (voxel indices), active voxels (bit `x·64 + y·8 + z`) and all 512 values.
#[derive(Clone, Debug)]
pub struct Leaf {
    pub origin: [u32; 3],
    pub active: [u64; 8],
    pub values: Vec<f32>,
}

/// A narrow-band level set (see the module docs).
#[derive(Clone, Debug)]
pub struct LevelSet {
    pub frame: GridFrame,
    /// Half-width × the largest voxel size.
    pub background: f32,
    /// The leaves, in OpenVDB's order (128³ node x-major, then leaf x-major inside it).
    pub leaves: Vec<Leaf>,
    /// The occupancy (bits along z): the sign of every inactive value.
    pub solid: VoxelGrid,
}

impl LevelSet {
    /// Active voxels.
    pub fn active_count(&self) -> u64 {
        self.leaves
            .iter()
            .map(|l| l.active.iter().map(|w| w.count_ones() as u64).sum::<u64>())
            .sum()
    }

    /// Whether voxel (i, j, k) is solid (false outside the grid).
    pub fn solid_at(&self, i: u32, j: u32, k: u32) -> bool {
        let [nx, ny, nz] = self.frame.dims;
        i < nx && j < ny && k < nz && self.solid.get(i, j, k)
    }
}

/// The band: the voxels within `r[a]` voxels along each axis of a set voxel of `surface` (bits along z).
pub fn dilate(surface: &VoxelGrid, r: [u32; 3]) -> VoxelGrid {
    let g = surface.to_axis(Axis::Z);
    let [nx, ny, nz] = g.frame.dims.map(|d| d as usize);
    let w = g.frame.words_per_column(Axis::Z) as usize;
    // Along z: r shifts up and down with carries between words, in place per column.
    let mut words = g.words.clone();
    words.par_chunks_mut(w).for_each(|col| {
        for _ in 0..r[2] {
            let src = col.to_vec();
            for x in 0..w {
                let up = src[x] << 1 | if x > 0 { src[x - 1] >> 31 } else { 0 };
                let down = src[x] >> 1 | if x + 1 < w { src[x + 1] << 31 } else { 0 };
                col[x] = src[x] | up | down;
            }
        }
        if nz % 32 != 0 {
            col[w - 1] &= (1u32 << (nz % 32)) - 1;
        }
    });
    // Along x, then y: each column ORs its neighbours within the radius.
    let along = |src: &[u32], radius: usize, x_axis: bool| -> Vec<u32> {
        let mut out = vec![0u32; src.len()];
        out.par_chunks_mut(w).enumerate().for_each(|(c, col)| {
            let (pos, len, step) = if x_axis {
                (c % nx, nx, 1)
            } else {
                (c / nx, ny, nx)
            };
            for p in pos.saturating_sub(radius)..=(pos + radius).min(len - 1) {
                let o = (c + p * step - pos * step) * w;
                for (v, s) in col.iter_mut().zip(&src[o..o + w]) {
                    *v |= s;
                }
            }
        });
        out
    };
    let words = along(&words, r[0] as usize, true);
    let words = along(&words, r[1] as usize, false);
    VoxelGrid {
        frame: g.frame,
        bit_axis: Axis::Z,
        words,
    }
}

/// A leaf region: its origin, its band voxels' and its solid voxels' bits (64 column bytes each), and
/// whether its voxels are all solid or all empty.
type LeafBits = ([u32; 3], [u8; 64], [u8; 64], bool);

/// Builds the level set of `solid` (the occupancy) given its `band` and a function giving the unsigned
/// distance at world points (called once, with every band voxel's centre).
pub fn build(
    solid: &VoxelGrid,
    band: &VoxelGrid,
    half_width: u32,
    distances: impl FnOnce(&[[f64; 3]]) -> crate::error::Result<Vec<f32>>,
) -> crate::error::Result<LevelSet> {
    let solid = solid.to_axis(Axis::Z);
    let band = band.to_axis(Axis::Z);
    let frame = solid.frame;
    let [nx, ny, nz] = frame.dims;
    let h = frame.voxel_size.iter().copied().fold(0.0, f64::max);
    let background = (half_width as f64 * h) as f32;
    // Leaf regions that need a leaf: any band voxel, or solid and empty voxels side by side.
    let per = |d: u32| d.div_ceil(128);
    let regions: Vec<[u32; 3]> = (0..per(nx))
        .flat_map(|a| (0..per(ny)).flat_map(move |b| (0..per(nz)).map(move |c| [a, b, c])))
        .collect();
    let leaf_list: Vec<Vec<LeafBits>> = regions
        .par_iter()
        .map(|node| {
            let mut out = Vec::new();
            for lx in 0..16 {
                for ly in 0..16 {
                    for lz in 0..16 {
                        let o = [
                            node[0] * 128 + 8 * lx,
                            node[1] * 128 + 8 * ly,
                            node[2] * 128 + 8 * lz,
                        ];
                        if o[0] >= nx || o[1] >= ny || o[2] >= nz {
                            continue;
                        }
                        let (b, s) = (leaf_mask(&band, o), leaf_mask(&solid, o));
                        let in_grid = o[0] + 8 <= nx && o[1] + 8 <= ny && o[2] + 8 <= nz;
                        let uniform =
                            s.iter().all(|&v| v == 0) || (in_grid && s.iter().all(|&v| v == 0xFF));
                        if b.iter().any(|&v| v != 0) || !uniform {
                            out.push((o, b, s, uniform));
                        }
                    }
                }
            }
            out
        })
        .collect();
    let leaf_list: Vec<_> = leaf_list.into_iter().flatten().collect();
    // The band's centres, leaf by leaf.
    let mut points = Vec::new();
    for (o, b, _, _) in &leaf_list {
        for n in 0..512u32 {
            if b[(n >> 3) as usize] >> (n & 7) & 1 == 1 {
                let (x, y, z) = (o[0] + (n >> 6), o[1] + (n >> 3 & 7), o[2] + (n & 7));
                points.push(frame.centre(x, y, z));
            }
        }
    }
    let d = distances(&points)?;
    let mut next = 0;
    let mut leaves = Vec::with_capacity(leaf_list.len());
    for (o, b, s, uniform) in leaf_list {
        let mut leaf = Leaf {
            origin: o,
            active: [0; 8],
            values: vec![0.0; 512],
        };
        for n in 0..512usize {
            let inside = s[n >> 3] >> (n & 7) & 1 == 1;
            let sign = if inside { -1.0 } else { 1.0 };
            leaf.values[n] = sign * background;
            if b[n >> 3] >> (n & 7) & 1 == 1 {
                let dist = d[next];
                next += 1;
                if dist < background {
                    leaf.values[n] = sign * dist;
                    leaf.active[n >> 6] |= 1 << (n & 63);
                }
            }
        }
        // A leaf of band voxels all beyond the background, of one sign, is a tile after all.
        if !uniform || leaf.active.iter().any(|&w| w != 0) {
            leaves.push(leaf);
        }
    }
    Ok(LevelSet {
        frame,
        background,
        leaves,
        solid,
    })
}
