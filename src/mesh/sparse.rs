//! A compressed-sparse-row matrix with `u32` indices, the one sparse format of the mesh module.
//!
//! Invariants: `row_ptr.len() == n_rows + 1`, `row_ptr[0] == 0`, `row_ptr` non-decreasing,
//! `col.len() == val.len() == row_ptr[n_rows]`, every `col < n_cols`. Built by the mesh module, columns
//! inside a row are strictly increasing (no duplicates) unless a builder documents otherwise.
//! The arrays are plain `u32` / `f64` / `f32` so they upload to a GPU storage buffer as they are
//! (`bytemuck::cast_slice`). [`SparseMatrix::spmv`] is a gather: one output per row, summed in row order,
//! so a GPU kernel doing the same loop reproduces it exactly in the same precision.
use glam::DVec3;

/// A CSR sparse matrix with `u32` row pointers and column indices and values of type `T`.
///
/// ```
/// use gregvox::mesh::SparseMatrix;
/// let m = SparseMatrix::from_triplets(2, 2, &[(0, 0, 1.0f32), (1, 1, 2.0)], |a, b| a + b);
/// let bytes: &[u8] = bytemuck::cast_slice(&m.col); // uploads as-is
/// assert_eq!(bytes.len(), 8);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct SparseMatrix<T> {
    /// Number of rows.
    pub n_rows: u32,
    /// Number of columns.
    pub n_cols: u32,
    /// Row pointers, `n_rows + 1` entries.
    pub row_ptr: Vec<u32>,
    /// Column index of each stored entry.
    pub col: Vec<u32>,
    /// Value of each stored entry.
    pub val: Vec<T>,
}

impl<T: Copy> SparseMatrix<T> {
    /// Builds a matrix from unsorted `(row, col, value)` triplets; duplicates are combined with `add`
    /// in input order, and columns inside each row end up strictly increasing (stable counting sort
    /// by row, then a per-row sort by column).
    ///
    /// ```
    /// use gregvox::mesh::SparseMatrix;
    /// let m = SparseMatrix::from_triplets(2, 3, &[(1, 2, 1.0), (0, 1, 2.0), (1, 2, 0.5)], |a, b| a + b);
    /// assert_eq!(m.row_ptr, vec![0, 1, 2]);
    /// assert_eq!(m.col, vec![1, 2]);
    /// assert_eq!(m.val, vec![2.0, 1.5]);
    /// ```
    pub fn from_triplets(
        n_rows: u32,
        n_cols: u32,
        triplets: &[(u32, u32, T)],
        add: impl Fn(T, T) -> T,
    ) -> Self {
        let mut count = vec![0u32; n_rows as usize + 1];
        for &(r, _, _) in triplets {
            count[r as usize + 1] += 1;
        }
        for i in 0..n_rows as usize {
            count[i + 1] += count[i];
        }
        let mut next = count.clone();
        let mut order = vec![0u32; triplets.len()];
        for (k, &(r, _, _)) in triplets.iter().enumerate() {
            order[next[r as usize] as usize] = k as u32;
            next[r as usize] += 1;
        }
        let mut row_ptr = Vec::with_capacity(n_rows as usize + 1);
        let mut col = Vec::with_capacity(triplets.len());
        let mut val = Vec::with_capacity(triplets.len());
        row_ptr.push(0u32);
        let mut scratch: Vec<u32> = Vec::new();
        for r in 0..n_rows as usize {
            scratch.clear();
            scratch.extend_from_slice(&order[count[r] as usize..count[r + 1] as usize]);
            // Stable: equal columns keep input order, so duplicates are added in input order.
            scratch.sort_by_key(|&k| triplets[k as usize].1);
            for &k in &scratch {
                let (_, c, v) = triplets[k as usize];
                if col.len() > *row_ptr.last().unwrap() as usize && *col.last().unwrap() == c {
                    let last = val.len() - 1;
                    val[last] = add(val[last], v);
                } else {
                    col.push(c);
                    val.push(v);
                }
            }
            row_ptr.push(col.len() as u32);
        }
        SparseMatrix {
            n_rows,
            n_cols,
            row_ptr,
            col,
            val,
        }
    }

    /// Number of stored entries.
    ///
    /// ```
    /// use gregvox::mesh::SparseMatrix;
    /// let m = SparseMatrix::from_triplets(1, 1, &[(0, 0, 1u32)], |a, b| a + b);
    /// assert_eq!(m.nnz(), 1);
    /// ```
    pub fn nnz(&self) -> usize {
        self.col.len()
    }

    /// The column indices and values of row `r`.
    ///
    /// ```
    /// use gregvox::mesh::SparseMatrix;
    /// let m = SparseMatrix::from_triplets(2, 2, &[(1, 0, 3u32), (1, 1, 4)], |a, b| a + b);
    /// assert_eq!(m.row(1), (&[0u32, 1][..], &[3u32, 4][..]));
    /// ```
    pub fn row(&self, r: usize) -> (&[u32], &[T]) {
        let (a, b) = (self.row_ptr[r] as usize, self.row_ptr[r + 1] as usize);
        (&self.col[a..b], &self.val[a..b])
    }

    /// The value at `(r, c)`, if stored (binary search: columns are sorted).
    ///
    /// ```
    /// use gregvox::mesh::SparseMatrix;
    /// let m = SparseMatrix::from_triplets(2, 2, &[(1, 0, 3u32)], |a, b| a + b);
    /// assert_eq!(m.get(1, 0), Some(3));
    /// assert_eq!(m.get(0, 0), None);
    /// ```
    pub fn get(&self, r: usize, c: u32) -> Option<T> {
        let (cols, vals) = self.row(r);
        cols.binary_search(&c).ok().map(|k| vals[k])
    }
}

impl SparseMatrix<f64> {
    /// Gather SpMV on 3-vectors: `y[r] = Σ_k val[k] · x[col[k]]`, summed in row order starting from zero.
    ///
    /// ```
    /// use gregvox::mesh::SparseMatrix;
    /// use glam::DVec3;
    /// let m = SparseMatrix::from_triplets(1, 2, &[(0, 0, 0.5), (0, 1, 0.5)], |a, b| a + b);
    /// let y = m.spmv(&[DVec3::ZERO, DVec3::new(2.0, 4.0, 6.0)]);
    /// assert_eq!(y, vec![DVec3::new(1.0, 2.0, 3.0)]);
    /// ```
    pub fn spmv(&self, x: &[DVec3]) -> Vec<DVec3> {
        assert_eq!(
            x.len(),
            self.n_cols as usize,
            "spmv: x has the wrong length"
        );
        let mut y = Vec::with_capacity(self.n_rows as usize);
        for r in 0..self.n_rows as usize {
            let (a, b) = (self.row_ptr[r] as usize, self.row_ptr[r + 1] as usize);
            let mut acc = DVec3::ZERO;
            for k in a..b {
                acc += self.val[k] * x[self.col[k] as usize];
            }
            y.push(acc);
        }
        y
    }

    /// The same matrix with `f32` values, for upload to a GPU.
    ///
    /// ```
    /// use gregvox::mesh::SparseMatrix;
    /// let m = SparseMatrix::from_triplets(1, 1, &[(0, 0, 0.25f64)], |a, b| a + b);
    /// assert_eq!(m.to_f32().val, vec![0.25f32]);
    /// ```
    pub fn to_f32(&self) -> SparseMatrix<f32> {
        SparseMatrix {
            n_rows: self.n_rows,
            n_cols: self.n_cols,
            row_ptr: self.row_ptr.clone(),
            col: self.col.clone(),
            val: self.val.iter().map(|&v| v as f32).collect(),
        }
    }

    /// Dense `self · other` restricted to sparse rows (a small SpGEMM used to compose subdivision levels;
    /// rows of the result have sorted, unique columns).
    ///
    /// ```
    /// use gregvox::mesh::SparseMatrix;
    /// let a = SparseMatrix::from_triplets(1, 2, &[(0, 0, 0.5), (0, 1, 0.5)], |a, b| a + b);
    /// let b = SparseMatrix::from_triplets(2, 1, &[(0, 0, 2.0), (1, 0, 4.0)], |a, b| a + b);
    /// assert_eq!(a.matmul(&b).val, vec![3.0]);
    /// ```
    pub fn matmul(&self, other: &SparseMatrix<f64>) -> SparseMatrix<f64> {
        assert_eq!(self.n_cols, other.n_rows, "matmul: inner dimensions differ");
        let mut row_ptr = vec![0u32];
        let mut col = Vec::new();
        let mut val = Vec::new();
        let mut acc = vec![0.0f64; other.n_cols as usize];
        let mut mark = vec![u32::MAX; other.n_cols as usize];
        let mut touched: Vec<u32> = Vec::new();
        for r in 0..self.n_rows as usize {
            touched.clear();
            let (ac, av) = self.row(r);
            for (&k, &w) in ac.iter().zip(av) {
                let (bc, bv) = other.row(k as usize);
                for (&c, &x) in bc.iter().zip(bv) {
                    if mark[c as usize] != r as u32 {
                        mark[c as usize] = r as u32;
                        acc[c as usize] = 0.0;
                        touched.push(c);
                    }
                    acc[c as usize] += w * x;
                }
            }
            touched.sort_unstable();
            for &c in &touched {
                col.push(c);
                val.push(acc[c as usize]);
            }
            row_ptr.push(col.len() as u32);
        }
        SparseMatrix {
            n_rows: self.n_rows,
            n_cols: other.n_cols,
            row_ptr,
            col,
            val,
        }
    }
}

impl SparseMatrix<f32> {
    /// Gather SpMV in `f32` on `[x, y, z]` rows, summed in row order: the CPU twin of the GPU kernel.
    ///
    /// ```
    /// use gregvox::mesh::SparseMatrix;
    /// let m = SparseMatrix::from_triplets(1, 2, &[(0, 0, 0.5f32), (0, 1, 0.5)], |a, b| a + b);
    /// assert_eq!(m.spmv_f32(&[[0.0; 3], [2.0, 4.0, 6.0]]), vec![[1.0, 2.0, 3.0]]);
    /// ```
    pub fn spmv_f32(&self, x: &[[f32; 3]]) -> Vec<[f32; 3]> {
        assert_eq!(
            x.len(),
            self.n_cols as usize,
            "spmv_f32: x has the wrong length"
        );
        let mut y = Vec::with_capacity(self.n_rows as usize);
        for r in 0..self.n_rows as usize {
            let (a, b) = (self.row_ptr[r] as usize, self.row_ptr[r + 1] as usize);
            let mut acc = [0.0f32; 3];
            for k in a..b {
                let w = self.val[k];
                let p = x[self.col[k] as usize];
                acc[0] += w * p[0];
                acc[1] += w * p[1];
                acc[2] += w * p[2];
            }
            y.push(acc);
        }
        y
    }
}
