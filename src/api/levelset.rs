//! Narrow-band signed distance level sets of voxelized meshes (`gregvox voxelize --what sdf --out X.vdb`):
//! the band and the leaves are `voxel::levelset`'s, the distances exact point-to-triangle distances (the
//! query's, through a distance tree over the triangles cut into pieces no longer than twice the band's
//! width, so that the slivers of one huge polygon do not overlap every band voxel), the sign the
//! voxelization's own occupancy (so the level set is negative exactly on the
//! solid voxels, the generalized winding number deciding on open meshes).
//!
//! Cost: seeds sampled on the surface (O(surface area in voxels), see `seeds`), the dilation (word operations),
//! then one distance query per band voxel, about (2·half-width + 1) × the surface voxels, pruned beyond the
//! half-width from the start; a band over [`MAX_BAND_VOXELS`] is refused before any distance is computed.
//! The worst case is many triangles genuinely within the half-width of a voxel (the centre of a fan of
//! 100,000 slivers: each voxel there visits them all), measured in `gregvox bench --suite writers`.
use super::{fan_local, local_origin, Mesh};
use crate::error::{Error, Result};
use crate::mesh::distance::{DistanceTree, Stack};
use crate::voxel::grid::{GridFrame, VoxelGrid};
use crate::voxel::levelset::{build, dilate, LevelSet};
use rayon::prelude::*;

pub use crate::voxel::levelset::HALF_WIDTH;

/// Most band voxels a level set may have (their centres and distances take about 28 bytes each).
pub const MAX_BAND_VOXELS: u64 = 1 << 27;

/// The narrow-band level set of `mesh` on `solid` (its voxelization), `half_width` voxels each side
/// (1–64; [`HALF_WIDTH`] = 3 is OpenVDB's default).
pub fn level_set(mesh: &Mesh, solid: &VoxelGrid, half_width: u32) -> Result<LevelSet> {
    if !(1..=64).contains(&half_width) {
        return Err(Error::Invalid(format!(
            "--half-width {half_width} is out of range: give 1 to 64 voxels"
        )));
    }
    let shift = local_origin(mesh);
    let tri = fan_local(mesh, shift);
    let local = GridFrame {
        origin: std::array::from_fn(|a| solid.frame.origin[a] - shift[a]),
        ..solid.frame
    };
    let h = solid.frame.voxel_size;
    let widest = h.iter().copied().fold(0.0, f64::max);
    let r = h.map(|x| (half_width as f64 * widest / x).ceil() as u32);
    let mut band = dilate(&seeds(&tri, &local, r), r.map(|x| x + 1));
    band.frame = solid.frame;
    let n = band.count();
    if n > MAX_BAND_VOXELS {
        return Err(Error::Invalid(format!(
            "the level set's band holds {n} voxels, more than the {MAX_BAND_VOXELS} allowed; use a smaller \
             --half-width or a coarser grid"
        )));
    }
    let limit = (half_width as f64 * widest) as f32 as f64 * (1.0 + 1e-6);
    // The distance tree over the triangles cut to pieces of at most twice the band's width (slivers get
    // tight boxes), at most 16 pieces per band voxel or 2^24.
    let triangles: Vec<[[f64; 3]; 3]> = tri
        .triangles
        .iter()
        .map(|t| t.map(|v| tri.positions[v as usize].map(f64::from)))
        .collect();
    let cap = (16 * n).clamp(triangles.len() as u64, 1 << 24) as usize;
    let tree = DistanceTree::new_split(&triangles, 2.0 * limit, cap);
    // Only distances below the background matter (the rest are inactive ±background): each query
    // prunes beyond it from the start.
    build(solid, &band, half_width, |points| {
        Ok(points
            .par_iter()
            .map_init(
                || (Stack::default(), None),
                |(stack, hint), p| {
                    // Points come leaf by leaf: the last answer bounds the next one at once.
                    let local = std::array::from_fn(|a| p[a] - shift[a]);
                    tree.closest_within_from(local, limit * limit, hint, stack)
                        .map_or(f32::INFINITY, |c| c.distance2.sqrt() as f32)
                },
            )
            .collect())
    })
}

/// The voxels holding samples of the triangles no farther than a quarter of the narrowest voxel apart:
/// every surface point lies within 0.28 voxel of one, so these seeds dilated by one voxel more than the
/// half-width hold every voxel whose centre is within the half-width of the surface. Cost: the surface
/// area in samples (16 per voxel²) plus the triangles' lengths, never a triangle's bounding box: the
/// slivers of a huge polygon's fan cost their length, not their box's area (where a triangle–box scan
/// took a minute on one 100,000-gon at 256³). Vertices outside the grid mark the nearest voxel of the
/// grid when they lie within `r + 1` voxels of it.
fn seeds(tri: &crate::voxel::mesh::TriMesh, frame: &GridFrame, r: [u32; 3]) -> VoxelGrid {
    use std::sync::atomic::{AtomicU32, Ordering};
    let dims = frame.dims;
    let w = frame.words_per_column(crate::voxel::grid::Axis::Z) as usize;
    let words: Vec<AtomicU32> = (0..dims[0] as usize * dims[1] as usize * w)
        .map(|_| AtomicU32::new(0))
        .collect();
    let limit = 0.5
        * frame
            .voxel_size
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
    let mark = |p: [f64; 3]| {
        let mut ijk = [0u32; 3];
        for a in 0..3 {
            let x = ((p[a] - frame.origin[a]) / frame.voxel_size[a]).floor();
            let reach = r[a] as f64 + 1.0;
            if !(x >= -reach - 1.0 && x < dims[a] as f64 + reach) {
                return;
            }
            ijk[a] = x.clamp(0.0, dims[a] as f64 - 1.0) as u32;
        }
        let at = (ijk[1] as usize * dims[0] as usize + ijk[0] as usize) * w + ijk[2] as usize / 32;
        words[at].fetch_or(1 << (ijk[2] % 32), Ordering::Relaxed);
    };
    // Each triangle sampled on rows parallel to its longest edge AB, rows and samples `step` apart (the
    // foot of C's altitude lies on AB, so each row's span shrinks towards C): every point of the triangle
    // lies within 1.12·step of a sample, and a sliver costs its length / step samples, not its box.
    let step = 0.5 * limit;
    tri.triangles.par_iter().for_each(|t| {
        let p = t.map(|v| tri.positions[v as usize].map(f64::from));
        let d2 = |a: [f64; 3], b: [f64; 3]| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>();
        let e = [d2(p[0], p[1]), d2(p[1], p[2]), d2(p[2], p[0])];
        let k = (0..3).max_by(|&x, &y| e[x].total_cmp(&e[y])).unwrap_or(0);
        let (a, b, c) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
        let ab: [f64; 3] = std::array::from_fn(|x| b[x] - a[x]);
        let len = e[k].sqrt();
        if !(len.is_finite() && len > step) {
            p.iter().for_each(|&q| mark(q));
            return;
        }
        let u = ab.map(|x| x / len);
        let ac: [f64; 3] = std::array::from_fn(|x| c[x] - a[x]);
        let xc = (0..3).map(|x| ac[x] * u[x]).sum::<f64>().clamp(0.0, len);
        let foot: [f64; 3] = std::array::from_fn(|x| a[x] + xc * u[x]);
        let height = d2(c, foot).sqrt();
        let rows = (height / step).ceil().max(1.0) as usize;
        for j in 0..=rows {
            let f = j as f64 / rows as f64;
            // The row at fraction f of the height: from A + f·(C − A) to B + f·(C − B).
            let l: [f64; 3] = std::array::from_fn(|x| a[x] + f * (c[x] - a[x]));
            let r: [f64; 3] = std::array::from_fn(|x| b[x] + f * (c[x] - b[x]));
            let n = (d2(l, r).sqrt() / step).ceil().max(1.0) as usize;
            for i in 0..=n {
                let g = i as f64 / n as f64;
                mark(std::array::from_fn(|x| l[x] + g * (r[x] - l[x])));
            }
        }
    });
    VoxelGrid {
        frame: *frame,
        bit_axis: crate::voxel::grid::Axis::Z,
        words: words.into_iter().map(AtomicU32::into_inner).collect(),
    }
}
