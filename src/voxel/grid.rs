//! The voxel grid contract (docs/ARCHITECTURE.md, "Voxel grids"): a box of X×Y×Z voxels of size
//! (hx, hy, hz) whose corner is `origin`; voxel (i,j,k) has its centre at
//! origin + ((i+½)·hx, (j+½)·hy, (k+½)·hz); a voxel is solid iff its centre is inside the solid (the whole
//! mesh decides, including parts outside the box).
//!
//! How the box is chosen ([`GridSpec`]): the box of the vertices the faces use (unreferenced vertices do not
//! count), or `bbox` when given; then `Res(R)` is a cubic R³ grid whose side is the box's longest extent,
//! `Dims([X,Y,Z])` divides the box into X×Y×Z voxels (voxel size extent_a / dims_a), `VoxelSize(h)` takes cubic
//! voxels of side h with dims_a = ceil(extent_a / h); `pad` adds that many empty voxels on every side (dims
//! grow by 2·pad, the origin moves by pad voxels).
//!
//! Storage: bit-packed u32 columns along one *bit axis*. For bit axis `a`, the column coordinates are the two
//! other axes in cyclic order `(u, v) = (a+1, a+2) mod 3` and the depth `d` is axis `a`; word
//! `(v·dims[u] + u)·W + d/32`, bit `d % 32`, with `W = ceil(dims[a]/32)` and unused bits zero. The GPU fill
//! writes the columns of its peel axis; [`VoxelGrid::to_axis`] re-lays a grid so grids from different axes
//! compare and vote bitwise.
use crate::error::{Error, Result};

/// Largest number of voxels along any axis (2048³ bits = 1 GiB).
pub const MAX_DIM: u32 = 2048;

/// A coordinate axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Axis {
    X = 0,
    Y = 1,
    Z = 2,
}

impl Axis {
    /// All three axes.
    pub const ALL: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];

    /// The axis with index 0, 1 or 2.
    pub fn from_index(i: usize) -> Axis {
        Axis::ALL[i % 3]
    }

    /// 0, 1 or 2.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The column axes `(u, v)` for this depth axis, in cyclic order.
    pub fn uv(self) -> (usize, usize) {
        ((self.index() + 1) % 3, (self.index() + 2) % 3)
    }

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        ["x", "y", "z"][self.index()]
    }
}

/// The placement of a grid in space: `dims` voxels per axis, each `voxel_size` wide, from the corner
/// `origin` (the box minimum).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct GridFrame {
    /// Voxels along x, y and z.
    pub dims: [u32; 3],
    /// The grid's minimum corner (world units).
    pub origin: [f64; 3],
    /// Edge lengths of one voxel along x, y and z (world units).
    pub voxel_size: [f64; 3],
}

impl GridFrame {
    /// A cubic `res`³ grid of cubic voxels spanning `side` from `origin`.
    ///
    /// ```
    /// use gregvox::voxel::grid::GridFrame;
    /// let f = GridFrame::cubic(4, [1.0, 0.0, 0.0], 2.0);
    /// assert_eq!((f.dims, f.voxel_size), ([4; 3], [0.5; 3]));
    /// assert_eq!(f.centre(0, 1, 3), [1.25, 0.75, 1.75]);
    /// ```
    pub fn cubic(res: u32, origin: [f64; 3], side: f64) -> GridFrame {
        GridFrame {
            dims: [res; 3],
            origin,
            voxel_size: [side / res as f64; 3],
        }
    }

    /// The cubic frame of the bounding box of `points` at resolution `res` (side = the longest extent).
    ///
    /// ```
    /// use gregvox::voxel::grid::GridFrame;
    /// let f = GridFrame::from_points(&[[0.0, 0.0, 0.0], [2.0, 1.0, 0.5]], 4).unwrap();
    /// assert_eq!((f.origin, f.voxel_size), ([0.0, 0.0, 0.0], [0.5; 3]));
    /// assert_eq!(f.centre(0, 1, 3), [0.25, 0.75, 1.75]);
    /// ```
    pub fn from_points(points: &[[f32; 3]], res: u32) -> Result<GridFrame> {
        let bounds = Bounds::of_points(points.iter().copied())?;
        GridSpec::res(res).frame(bounds)
    }

    /// Edge length of one voxel along `axis`.
    pub fn size(&self, axis: Axis) -> f64 {
        self.voxel_size[axis.index()]
    }

    /// Centre of voxel (i, j, k).
    pub fn centre(&self, i: u32, j: u32, k: u32) -> [f64; 3] {
        let ijk = [i, j, k];
        std::array::from_fn(|a| self.origin[a] + (ijk[a] as f64 + 0.5) * self.voxel_size[a])
    }

    /// The 4×4 matrix (row-major) taking a voxel index (i, j, k, 1) to its centre in world coordinates.
    ///
    /// ```
    /// use gregvox::voxel::grid::GridFrame;
    /// let f = GridFrame { dims: [2, 3, 4], origin: [1.0, 2.0, 3.0], voxel_size: [0.5, 1.0, 2.0] };
    /// let m = f.index_to_world();
    /// let c = f.centre(1, 2, 3);
    /// for a in 0..3 {
    ///     assert_eq!(m[a][0] * 1.0 + m[a][1] * 2.0 + m[a][2] * 3.0 + m[a][3], c[a]);
    /// }
    /// ```
    pub fn index_to_world(&self) -> [[f64; 4]; 4] {
        let mut m = [[0.0; 4]; 4];
        for (a, row) in m.iter_mut().enumerate().take(3) {
            row[a] = self.voxel_size[a];
            row[3] = self.origin[a] + 0.5 * self.voxel_size[a];
        }
        m[3][3] = 1.0;
        m
    }

    /// Whether the voxels are cubes (equal sizes on every axis).
    pub fn cubic_voxels(&self) -> bool {
        self.voxel_size[0] == self.voxel_size[1] && self.voxel_size[1] == self.voxel_size[2]
    }

    /// `Some(R)` for an R³ grid of cubic voxels (the demo's ray caster draws only those).
    pub fn cubic_res(&self) -> Option<u32> {
        let [x, y, z] = self.dims;
        (x == y && y == z && self.cubic_voxels()).then_some(x)
    }

    /// u32 words per column of bit axis `axis`.
    pub fn words_per_column(&self, axis: Axis) -> u32 {
        self.dims[axis.index()].div_ceil(32)
    }

    /// Columns of bit axis `axis`: `dims[u] · dims[v]`.
    pub fn columns(&self, axis: Axis) -> u64 {
        let (u, v) = axis.uv();
        self.dims[u] as u64 * self.dims[v] as u64
    }

    /// Number of voxels.
    pub fn voxel_count(&self) -> u64 {
        self.dims.iter().map(|&d| d as u64).product()
    }

    /// Checks what every consumer relies on: 1–[`MAX_DIM`] voxels per axis, finite origin, finite positive
    /// voxel sizes.
    pub fn validate(&self) -> Result<()> {
        for a in Axis::ALL {
            let (d, h, o) = (self.dims[a.index()], self.size(a), self.origin[a.index()]);
            if d == 0 || d > MAX_DIM {
                return Err(Error::Invalid(format!(
                    "the grid has {d} voxels along {}: it must have between 1 and {MAX_DIM}",
                    a.name()
                )));
            }
            if !(h.is_finite() && h > 0.0) {
                return Err(Error::Invalid(format!(
                    "the voxel size along {} is {h}: it must be finite and positive",
                    a.name()
                )));
            }
            if !o.is_finite() || !(o + d as f64 * h).is_finite() {
                return Err(Error::Invalid(format!(
                    "the grid's extent along {} is not finite",
                    a.name()
                )));
            }
        }
        Ok(())
    }
}

/// An axis-aligned box: `[min, max]`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Bounds {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

impl Bounds {
    /// The box of `points` (an error if there are none or one is not finite).
    pub fn of_points(points: impl IntoIterator<Item = [f32; 3]>) -> Result<Bounds> {
        let mut b = Bounds {
            min: [f64::INFINITY; 3],
            max: [f64::NEG_INFINITY; 3],
        };
        let mut any = false;
        for p in points {
            any = true;
            for (a, &c) in p.iter().enumerate() {
                let x = c as f64;
                if !x.is_finite() {
                    return Err(Error::Invalid(
                        "a vertex coordinate is NaN or infinite".into(),
                    ));
                }
                b.min[a] = b.min[a].min(x);
                b.max[a] = b.max[a].max(x);
            }
        }
        if !any {
            return Err(Error::Invalid("the mesh has no vertices".into()));
        }
        Ok(b)
    }

    /// The box of the vertices `triangles` use (vertices no triangle uses do not count).
    ///
    /// ```
    /// use gregvox::voxel::grid::Bounds;
    /// let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [7.0, 7.0, 7.0]];
    /// let b = Bounds::of_triangles(&p, &[[0, 1, 2]]).unwrap();
    /// assert_eq!((b.min, b.max), ([0.0; 3], [1.0, 1.0, 0.0]));
    /// ```
    pub fn of_triangles(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Result<Bounds> {
        let mut used = vec![false; positions.len()];
        for t in triangles {
            for &v in t {
                if let Some(u) = used.get_mut(v as usize) {
                    *u = true;
                }
            }
        }
        Bounds::of_points(
            positions
                .iter()
                .zip(&used)
                .filter(|(_, &u)| u)
                .map(|(p, _)| *p),
        )
    }

    /// Extent along each axis.
    pub fn extent(&self) -> [f64; 3] {
        std::array::from_fn(|a| self.max[a] - self.min[a])
    }
}

/// How many voxels, or how large.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GridSize {
    /// A cubic R³ grid whose side is the box's longest extent (`--res R`).
    Res(u32),
    /// The box divided into X×Y×Z voxels (`--dims X,Y,Z`).
    Dims([u32; 3]),
    /// Cubic voxels of this side, dims_a = ceil(extent_a / h) from the box's minimum (`--voxel-size H`).
    VoxelSize(f64),
}

/// Where the grid goes and how fine it is (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct GridSpec {
    pub size: GridSize,
    /// The box to voxelize instead of the mesh's (`--bbox`).
    pub bbox: Option<Bounds>,
    /// Empty voxels added on every side (`--pad N`).
    pub pad: u32,
}

impl GridSpec {
    /// A cubic R³ grid over the mesh's box, no padding.
    pub fn res(res: u32) -> GridSpec {
        GridSpec {
            size: GridSize::Res(res),
            bbox: None,
            pad: 0,
        }
    }

    /// The frame over `mesh_box` (or `bbox` when set).
    ///
    /// ```
    /// use gregvox::voxel::grid::{Bounds, GridSize, GridSpec};
    /// let b = Bounds { min: [0.0; 3], max: [2.0, 1.0, 0.5] };
    /// let f = GridSpec { size: GridSize::VoxelSize(0.3), bbox: None, pad: 1 }.frame(b).unwrap();
    /// assert_eq!(f.dims, [7 + 2, 4 + 2, 2 + 2]);
    /// assert_eq!(f.origin, [-0.3, -0.3, -0.3]);
    /// let f = GridSpec { size: GridSize::Dims([4, 2, 1]), bbox: None, pad: 0 }.frame(b).unwrap();
    /// assert_eq!(f.voxel_size, [0.5, 0.5, 0.5]);
    /// ```
    pub fn frame(&self, mesh_box: Bounds) -> Result<GridFrame> {
        let b = match self.bbox {
            Some(b) => {
                for a in 0..3 {
                    if !(b.min[a].is_finite() && b.max[a].is_finite() && b.min[a] < b.max[a]) {
                        return Err(Error::Invalid(format!(
                            "--bbox: the box must have finite corners with min < max on every axis \
                             (along {}: {} .. {})",
                            Axis::from_index(a).name(),
                            b.min[a],
                            b.max[a]
                        )));
                    }
                }
                b
            }
            None => mesh_box,
        };
        let ext = b.extent();
        let (dims, voxel_size) = match self.size {
            GridSize::Res(r) => {
                if r == 0 || r > MAX_DIM {
                    return Err(Error::Invalid(format!(
                        "--res {r} is out of range: the resolution must be between 1 and {MAX_DIM}"
                    )));
                }
                let side = ext.iter().copied().fold(0.0, f64::max);
                if side <= 0.0 {
                    return Err(Error::Invalid(
                        "the mesh's bounding box is a single point".into(),
                    ));
                }
                ([r; 3], [side / r as f64; 3])
            }
            GridSize::Dims(d) => {
                let mut size = [0.0; 3];
                for a in 0..3 {
                    if d[a] == 0 || d[a] > MAX_DIM {
                        return Err(Error::Invalid(format!(
                            "--dims {},{},{}: every axis needs between 1 and {MAX_DIM} voxels",
                            d[0], d[1], d[2]
                        )));
                    }
                    if ext[a] <= 0.0 {
                        return Err(Error::Invalid(format!(
                            "--dims: the box has no extent along {} (the mesh is flat), so its voxels \
                             would have no size; give --bbox or --voxel-size",
                            Axis::from_index(a).name()
                        )));
                    }
                    size[a] = ext[a] / d[a] as f64;
                }
                (d, size)
            }
            GridSize::VoxelSize(h) => {
                if !(h.is_finite() && h > 0.0) {
                    return Err(Error::Invalid(format!(
                        "--voxel-size {h}: the voxel size must be a finite number > 0"
                    )));
                }
                let mut d = [0u32; 3];
                for a in 0..3 {
                    let n = (ext[a] / h).ceil().max(1.0);
                    if n > MAX_DIM as f64 {
                        return Err(Error::Invalid(format!(
                            "--voxel-size {h}: the box is {} long along {}, which takes {n} voxels \
                             (at most {MAX_DIM} per axis)",
                            ext[a],
                            Axis::from_index(a).name()
                        )));
                    }
                    d[a] = n as u32;
                }
                (d, [h; 3])
            }
        };
        let pad = self.pad as u64;
        let mut frame = GridFrame {
            dims,
            origin: b.min,
            voxel_size,
        };
        for a in 0..3 {
            let n = dims[a] as u64 + 2 * pad;
            if n > MAX_DIM as u64 {
                return Err(Error::Invalid(format!(
                    "--pad {pad}: {} + 2·{pad} voxels along {} pass the limit of {MAX_DIM}",
                    dims[a],
                    Axis::from_index(a).name()
                )));
            }
            frame.dims[a] = n as u32;
            frame.origin[a] -= pad as f64 * voxel_size[a];
        }
        frame.validate()?;
        Ok(frame)
    }
}
/// A bit-packed solid voxel grid. See the module invariants for the layout.
#[derive(Clone, Debug, PartialEq)]
pub struct VoxelGrid {
    pub frame: GridFrame,
    /// The axis along which the bits of a column run.
    pub bit_axis: Axis,
    pub words: Vec<u32>,
}

impl VoxelGrid {
    /// An empty grid.
    pub fn empty(frame: GridFrame, bit_axis: Axis) -> VoxelGrid {
        let n = Self::bytes_for(&frame, bit_axis) / 4;
        VoxelGrid {
            frame,
            bit_axis,
            words: vec![0; n as usize],
        }
    }

    /// Bytes of the packed grid for `frame` with bits along `bit_axis`.
    pub fn bytes_for(frame: &GridFrame, bit_axis: Axis) -> u64 {
        frame.columns(bit_axis) * frame.words_per_column(bit_axis) as u64 * 4
    }

    /// The words of column (u, v) of the bit axis: `dims[bit axis]` bits, low bit first.
    pub fn column(&self, u: u32, v: u32) -> &[u32] {
        let (ua, _) = self.bit_axis.uv();
        let w = self.frame.words_per_column(self.bit_axis) as usize;
        let start = (v as usize * self.frame.dims[ua] as usize + u as usize) * w;
        &self.words[start..start + w]
    }

    fn locate(&self, ijk: [u32; 3]) -> (usize, u32) {
        let (ua, va) = self.bit_axis.uv();
        let (u, v, d) = (
            ijk[ua] as usize,
            ijk[va] as usize,
            ijk[self.bit_axis.index()],
        );
        let nu = self.frame.dims[ua] as usize;
        let w = self.frame.words_per_column(self.bit_axis) as usize;
        ((v * nu + u) * w + (d / 32) as usize, d % 32)
    }

    /// Whether voxel (i, j, k) is solid.
    pub fn get(&self, i: u32, j: u32, k: u32) -> bool {
        let (w, b) = self.locate([i, j, k]);
        self.words[w] >> b & 1 == 1
    }

    /// Sets voxel (i, j, k).
    pub fn set(&mut self, i: u32, j: u32, k: u32, value: bool) {
        let (w, b) = self.locate([i, j, k]);
        if value {
            self.words[w] |= 1 << b;
        } else {
            self.words[w] &= !(1 << b);
        }
    }

    /// Writes the occupancy one byte per voxel (1 solid, 0 empty) in C order `[x][y][z]`, z fastest: the
    /// layout of a NumPy `(X, Y, Z)` array indexed `[x, y, z]`. `out` holds [`GridFrame::voxel_count`] bytes.
    ///
    /// ```
    /// use gregvox::voxel::grid::{Axis, GridFrame, VoxelGrid};
    /// let mut g = VoxelGrid::empty(GridFrame::cubic(3, [0.0; 3], 1.0), Axis::X);
    /// g.set(2, 1, 0, true);
    /// let mut dense = vec![0u8; 27];
    /// g.write_dense_xyz(&mut dense);
    /// assert_eq!(dense.iter().position(|&b| b == 1), Some((2 * 3 + 1) * 3));
    /// assert_eq!(dense.iter().map(|&b| b as u32).sum::<u32>(), 1);
    /// ```
    pub fn write_dense_xyz(&self, out: &mut [u8]) {
        assert_eq!(
            out.len() as u64,
            self.frame.voxel_count(),
            "one byte per voxel"
        );
        let [nx, ny, nz] = self.frame.dims.map(|d| d as usize);
        if self.bit_axis == Axis::Z {
            // Bits along z are the dense rows: unpack each column's words in one pass.
            for x in 0..nx {
                for y in 0..ny {
                    let column = self.column(x as u32, y as u32);
                    let row = &mut out[(x * ny + y) * nz..(x * ny + y + 1) * nz];
                    for (z, b) in row.iter_mut().enumerate() {
                        *b = (column[z / 32] >> (z % 32) & 1) as u8;
                    }
                }
            }
            return;
        }
        // Bits along x or y: within a dense row (x, y fixed, z running) the bit is fixed and z steps
        // through whole columns, so the row reads one word per voxel at a constant stride. No transpose.
        let stride = self.locate([0, 0, 1]).0 - self.locate([0, 0, 0]).0;
        for x in 0..nx {
            for y in 0..ny {
                let (base, shift) = self.locate([x as u32, y as u32, 0]);
                let row = &mut out[(x * ny + y) * nz..(x * ny + y + 1) * nz];
                for (z, b) in row.iter_mut().enumerate() {
                    *b = (self.words[base + z * stride] >> shift & 1) as u8;
                }
            }
        }
    }

    /// Number of solid voxels.
    pub fn count(&self) -> u64 {
        self.words.iter().map(|w| w.count_ones() as u64).sum()
    }

    /// The same voxels with bits along `axis`.
    ///
    /// Cost: O(voxels / 32) word operations, no per-voxel work: 32 source columns that are consecutive along
    /// the new bit axis, one word of each, form a 32 × 32 bit block that one transpose turns into one word
    /// of each of 32 new columns. Planes of the third axis (or 32-row bands) run in parallel; 1024³ takes
    /// tens of milliseconds.
    pub fn to_axis(&self, axis: Axis) -> VoxelGrid {
        if axis == self.bit_axis {
            return self.clone();
        }
        use rayon::prelude::*;
        let dims = self.frame.dims.map(|n| n as usize);
        let (d, e) = (self.bit_axis.index(), axis.index());
        let f = 3 - d - e;
        let (su, sv) = self.bit_axis.uv();
        let (tu, tv) = axis.uv();
        let nws = self.frame.words_per_column(self.bit_axis) as usize;
        let nwt = self.frame.words_per_column(axis) as usize;
        let mut out = VoxelGrid::empty(self.frame, axis);
        let src = &self.words;
        // The 32 rows of block (e-word `eb`, d-word `dw`) in plane `fv`, transposed: row s holds bits
        // e = 32·eb .. of the new column at d = 32·dw + s.
        let block = |fv: usize, eb: usize, dw: usize| -> [u32; 32] {
            let mut rows = [0u32; 32];
            for (t, row) in rows.iter_mut().enumerate() {
                let ev = eb * 32 + t;
                if ev >= dims[e] {
                    break;
                }
                let mut ijk = [0usize; 3];
                ijk[e] = ev;
                ijk[f] = fv;
                *row = src[(ijk[sv] * dims[su] + ijk[su]) * nws + dw];
            }
            transpose32(&mut rows);
            rows
        };
        if tv == f {
            // One chunk per plane f = v: its columns run along u = d.
            out.words
                .par_chunks_mut(dims[tu] * nwt)
                .enumerate()
                .for_each(|(fv, chunk)| {
                    for eb in 0..nwt {
                        for dw in 0..nws {
                            let rows = block(fv, eb, dw);
                            for (s, &row) in rows.iter().enumerate() {
                                let dv = dw * 32 + s;
                                if dv >= dims[d] {
                                    break;
                                }
                                chunk[dv * nwt + eb] = row;
                            }
                        }
                    }
                });
        } else {
            // v = d: a chunk is a band of 32 values of d (one source word), every plane f = u inside.
            debug_assert!(tv == d && tu == f);
            out.words
                .par_chunks_mut(32 * dims[tu] * nwt)
                .enumerate()
                .for_each(|(dw, chunk)| {
                    let rows_here = chunk.len() / (dims[tu] * nwt);
                    for fv in 0..dims[f] {
                        for eb in 0..nwt {
                            let rows = block(fv, eb, dw);
                            for (s, &row) in rows.iter().take(rows_here).enumerate() {
                                chunk[(s * dims[tu] + fv) * nwt + eb] = row;
                            }
                        }
                    }
                });
        }
        // Bits past dims[e] in each new column's last word: the transposed rows of absent source columns
        // (t ≥ dims[e]) were zero, so nothing to clear.
        out
    }

    /// Voxels set in exactly one of the two grids (any bit axes; same frame dims).
    pub fn count_differences(&self, other: &VoxelGrid) -> u64 {
        let o = other.to_axis(self.bit_axis);
        self.words
            .iter()
            .zip(&o.words)
            .map(|(a, b)| (a ^ b).count_ones() as u64)
            .sum()
    }

    /// Intersection over union of the solid sets (1 when both are empty).
    pub fn iou(&self, other: &VoxelGrid) -> f64 {
        let o = other.to_axis(self.bit_axis);
        let (mut inter, mut union) = (0u64, 0u64);
        for (a, b) in self.words.iter().zip(&o.words) {
            inter += (a & b).count_ones() as u64;
            union += (a | b).count_ones() as u64;
        }
        if union == 0 {
            1.0
        } else {
            inter as f64 / union as f64
        }
    }

    /// The voxels solid in either grid (same frame, any bit axes), with `self`'s bit axis.
    pub fn union(&self, other: &VoxelGrid) -> VoxelGrid {
        let o = other.to_axis(self.bit_axis);
        let mut out = self.clone();
        for (a, b) in out.words.iter_mut().zip(&o.words) {
            *a |= b;
        }
        out
    }

    /// The 2-of-3 majority of three grids of the same frame (any bit axes), with bits along `Z`.
    pub fn majority(grids: [&VoxelGrid; 3]) -> VoxelGrid {
        let [a, b, c] = grids.map(|g| g.to_axis(Axis::Z));
        let words = a
            .words
            .iter()
            .zip(&b.words)
            .zip(&c.words)
            .map(|((a, b), c)| (a & b) | (b & c) | (a & c))
            .collect();
        VoxelGrid {
            frame: a.frame,
            bit_axis: Axis::Z,
            words,
        }
    }
}

/// Transposes a 32 × 32 bit matrix in place: afterwards bit s of `a[t]` is the former bit t of `a[s]`
/// (Hacker's Delight §7-3, for low-bit-first rows).
pub fn transpose32(a: &mut [u32; 32]) {
    let (mut j, mut m) = (16usize, 0x0000_FFFFu32);
    while j != 0 {
        let mut k = 0usize;
        while k < 32 {
            let t = ((a[k] >> j) ^ a[k + j]) & m;
            a[k] ^= t << j;
            a[k + j] ^= t;
            k = (k + j + 1) & !j;
        }
        j >>= 1;
        m ^= m << j;
    }
}
