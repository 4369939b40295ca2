//! The voxel grid contract (docs/ARCHITECTURE.md): a cubic R×R×R grid whose origin is the mesh's bounding-box
//! minimum and whose side is the box's longest extent; voxel (i,j,k) has its centre at origin + (i+½, j+½,
//! k+½)·pitch; a voxel is solid iff its centre is inside the solid.
//!
//! Storage: bit-packed u32 columns along one *bit axis*. For bit axis `a`, the column coordinates are the two
//! other axes in cyclic order `(u, v) = (a+1, a+2) mod 3` and the depth `d` is axis `a`; word
//! `(v·R + u)·W + d/32`, bit `d % 32`, with `W = ceil(R/32)` and unused bits zero. The GPU fill writes the
//! columns of its peel axis; [`VoxelGrid::to_axis`] re-lays a grid so grids from different axes compare and
//! vote bitwise.
use crate::error::{Error, Result};

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

/// The placement of a grid in space.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct GridFrame {
    /// Voxels per side.
    pub res: u32,
    /// The bounding-box minimum.
    pub origin: [f64; 3],
    /// The longest bounding-box extent (the cube's side).
    pub side: f64,
}

impl GridFrame {
    /// The frame of a mesh's bounding box at resolution `res`.
    ///
    /// ```
    /// use gregvox::voxel::grid::GridFrame;
    /// let f = GridFrame::from_points(&[[0.0, 0.0, 0.0], [2.0, 1.0, 0.5]], 4).unwrap();
    /// assert_eq!((f.origin, f.side, f.pitch()), ([0.0, 0.0, 0.0], 2.0, 0.5));
    /// assert_eq!(f.centre(0, 1, 3), [0.25, 0.75, 1.75]);
    /// ```
    pub fn from_points(points: &[[f32; 3]], res: u32) -> Result<GridFrame> {
        if res == 0 {
            return Err(Error::Invalid("the resolution must be at least 1".into()));
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in points {
            for a in 0..3 {
                let x = p[a] as f64;
                if !x.is_finite() {
                    return Err(Error::Invalid(
                        "a vertex coordinate is NaN or infinite".into(),
                    ));
                }
                lo[a] = lo[a].min(x);
                hi[a] = hi[a].max(x);
            }
        }
        if points.is_empty() {
            return Err(Error::Invalid("the mesh has no vertices".into()));
        }
        let side = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
        if side <= 0.0 {
            return Err(Error::Invalid(
                "the mesh's bounding box is a single point".into(),
            ));
        }
        Ok(GridFrame {
            res,
            origin: lo,
            side,
        })
    }

    /// Edge length of one voxel.
    pub fn pitch(&self) -> f64 {
        self.side / self.res as f64
    }

    /// Centre of voxel (i, j, k).
    pub fn centre(&self, i: u32, j: u32, k: u32) -> [f64; 3] {
        let p = self.pitch();
        [
            self.origin[0] + (i as f64 + 0.5) * p,
            self.origin[1] + (j as f64 + 0.5) * p,
            self.origin[2] + (k as f64 + 0.5) * p,
        ]
    }

    /// u32 words per column.
    pub fn words_per_column(&self) -> u32 {
        self.res.div_ceil(32)
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
        let n = frame.res as usize * frame.res as usize * frame.words_per_column() as usize;
        VoxelGrid {
            frame,
            bit_axis,
            words: vec![0; n],
        }
    }

    /// Bytes of the packed grid for `frame`.
    pub fn bytes_for(frame: &GridFrame) -> u64 {
        frame.res as u64 * frame.res as u64 * frame.words_per_column() as u64 * 4
    }

    fn locate(&self, ijk: [u32; 3]) -> (usize, u32) {
        let (ua, va) = self.bit_axis.uv();
        let (u, v, d) = (
            ijk[ua] as usize,
            ijk[va] as usize,
            ijk[self.bit_axis.index()],
        );
        let r = self.frame.res as usize;
        let w = self.frame.words_per_column() as usize;
        ((v * r + u) * w + (d / 32) as usize, d % 32)
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

    /// Number of solid voxels.
    pub fn count(&self) -> u64 {
        self.words.iter().map(|w| w.count_ones() as u64).sum()
    }

    /// The same voxels with bits along `axis`.
    pub fn to_axis(&self, axis: Axis) -> VoxelGrid {
        if axis == self.bit_axis {
            return self.clone();
        }
        let mut out = VoxelGrid::empty(self.frame, axis);
        let r = self.frame.res;
        let w = self.frame.words_per_column() as usize;
        let (ua, va) = self.bit_axis.uv();
        let da = self.bit_axis.index();
        for v in 0..r {
            for u in 0..r {
                let base = (v as usize * r as usize + u as usize) * w;
                for (wi, &word) in self.words[base..base + w].iter().enumerate() {
                    let mut bits = word;
                    while bits != 0 {
                        let b = bits.trailing_zeros();
                        bits &= bits - 1;
                        let mut ijk = [0u32; 3];
                        ijk[ua] = u;
                        ijk[va] = v;
                        ijk[da] = wi as u32 * 32 + b;
                        out.set(ijk[0], ijk[1], ijk[2], true);
                    }
                }
            }
        }
        out
    }

    /// Voxels set in exactly one of the two grids (any bit axes; same frame resolution).
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
