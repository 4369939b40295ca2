//! CPU reference tessellator: every patch on a (L+1)² grid, the f64 twin of the GPU evaluation pass.
//!
//! Invariants (docs/ARCHITECTURE.md, "Tessellation output"):
//! - patch `p` owns vertices `p·(L+1)² ..`; its vertex `j·(L+1) + i` is at (u, v) = (i/L, j/L), u along the
//!   face's first edge (v0→v1), v along v0→v3, rows of u inner;
//! - normals are unit length and never NaN ([`PatchF64::normal`] falls back on degenerate derivatives);
//! - [`indices`] gives two triangles per grid cell, counter-clockwise in (u, v), so their winding agrees
//!   with S_u × S_v, the outward normal of a counter-clockwise cage face;
//! - a level of 0 is treated as 1 (one cell per patch), so no input panics.
use crate::error::{Error, Result};
use crate::geom::gregory::PatchF64;
use glam::DVec3;
use std::path::Path;

/// Positions and unit normals of all patch grids, patch-major.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tessellation {
    /// Grid positions.
    pub positions: Vec<DVec3>,
    /// Unit normals, one per position.
    pub normals: Vec<DVec3>,
}

/// Evaluates every patch on its (L+1)² grid.
///
/// ```
/// use gregvox::geom::gregory::PatchF64;
/// use gregvox::surface::tessellate;
/// use glam::DVec3;
/// let b: [[DVec3; 4]; 4] = std::array::from_fn(|j| std::array::from_fn(|i| DVec3::new(i as f64, j as f64, 0.0)));
/// let t = tessellate(&[PatchF64::from_bezier(&b)], 2);
/// assert_eq!(t.positions.len(), 9);
/// assert_eq!(t.positions[1], DVec3::new(1.5, 0.0, 0.0)); // (u, v) = (1/2, 0)
/// assert_eq!(t.positions[3], DVec3::new(0.0, 1.5, 0.0)); // (u, v) = (0, 1/2)
/// assert_eq!(t.normals[4], DVec3::Z);
/// ```
pub fn tessellate(patches: &[PatchF64], level: u32) -> Tessellation {
    let l = level.max(1) as usize;
    let n = (l + 1) * (l + 1);
    let mut out = Tessellation {
        positions: Vec::with_capacity(patches.len() * n),
        normals: Vec::with_capacity(patches.len() * n),
    };
    for p in patches {
        for j in 0..=l {
            // t = i/L from the integer index, so shared edges see the same parameters.
            let v = j as f64 / l as f64;
            for i in 0..=l {
                let u = i as f64 / l as f64;
                out.positions.push(p.eval(u, v).0);
                out.normals.push(p.normal(u, v));
            }
        }
    }
    out
}

/// Triangle indices for `n_patches` grids of level L: two CCW triangles per cell, 6·L² per patch.
///
/// ```
/// use gregvox::surface::indices;
/// assert_eq!(indices(1, 2), vec![0, 1, 3, 0, 3, 2, 4, 5, 7, 4, 7, 6]);
/// ```
pub fn indices(level: u32, n_patches: usize) -> Vec<u32> {
    let l = level.max(1);
    let row = l + 1;
    let per = row * row;
    let mut idx = Vec::with_capacity(n_patches * 6 * (l * l) as usize);
    for p in 0..n_patches as u32 {
        let base = p * per;
        for j in 0..l {
            for i in 0..l {
                let a = base + j * row + i;
                let (b, c, d) = (a + 1, a + row + 1, a + row);
                idx.extend_from_slice(&[a, b, c, a, c, d]);
            }
        }
    }
    idx
}

/// Writes `v`, `vn` and `f a//a b//b c//c` lines to `path` through [`crate::io::write_atomic`] (a temporary
/// file beside it, then a rename), so a reader never sees a half-written file.
///
/// ```
/// use gregvox::geom::gregory::PatchF64;
/// use gregvox::surface::{tessellate, write_tessellation_obj};
/// use glam::DVec3;
/// let b: [[DVec3; 4]; 4] = std::array::from_fn(|j| std::array::from_fn(|i| DVec3::new(i as f64, j as f64, 0.0)));
/// let t = tessellate(&[PatchF64::from_bezier(&b)], 1);
/// let path = std::env::temp_dir().join(format!("gregvox_tess_doc_{}.obj", std::process::id()));
/// write_tessellation_obj(&path, &t, 1).unwrap();
/// let text = std::fs::read_to_string(&path).unwrap();
/// assert_eq!(text.lines().filter(|l| l.starts_with("vn ")).count(), 4);
/// assert!(text.contains("f 1//1 2//2 4//4"));
/// std::fs::remove_file(&path).unwrap();
/// ```
pub fn write_tessellation_obj(path: impl AsRef<Path>, t: &Tessellation, level: u32) -> Result<()> {
    let path = path.as_ref();
    let l = level.max(1) as usize;
    let per = (l + 1) * (l + 1);
    if t.positions.len() != t.normals.len() || t.positions.len() % per != 0 {
        return Err(Error::Invalid(format!(
            "{}: tessellation has {} positions and {} normals, not a multiple of (L+1)² = {per}",
            path.display(),
            t.positions.len(),
            t.normals.len()
        )));
    }
    crate::io::write_atomic(path, |w| {
        writeln!(
            w,
            "# gregvox tessellation: level {l}, {} patches",
            t.positions.len() / per
        )?;
        for p in &t.positions {
            writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
        }
        for n in &t.normals {
            writeln!(w, "vn {} {} {}", n.x, n.y, n.z)?;
        }
        for tri in indices(l as u32, t.positions.len() / per).chunks(3) {
            let (a, b, c) = (tri[0] + 1, tri[1] + 1, tri[2] + 1);
            writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
        }
        Ok(())
    })
}
