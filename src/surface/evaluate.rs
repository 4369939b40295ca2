//! The limit surface at arbitrary parameters: `(face, u, v)` → position, exact first and second
//! derivatives, on the CPU in f64 (OpenSubdiv's `Far::PatchMap` + `EvaluateBasis`, with exact Gregory
//! derivatives where OpenSubdiv's are an approximation).
//!
//! Invariants:
//! - `face` is a ptex face as OpenSubdiv numbers them (`Far::PtexIndices`): the cage's faces in order, a quad
//!   one ptex face, an n-gon (n ≠ 4) n of them, its sub-face i the quad at its corner i with (0, 0) at the
//!   corner's vertex, u toward the midpoint of the next edge and v toward the midpoint of the previous one.
//!   An all-quad cage's ptex faces are its faces.
//! - A cage with non-quad faces was refined once ([`GregoryStencils::from_cage`]), every face split into the
//!   quads at its corners: a quad's (u, v) picks the quadrant and is mapped onto that child's own (u, v) by
//!   a rotation and a scale by 2, and the derivatives are mapped back by the chain rule (Jacobian entries
//!   0, ±2), so they are the derivatives with respect to the ptex face's own (u, v).
//! - u and v must lie in [0, 1] and be finite; the face must exist and not be a hole: anything else is an
//!   error naming the row, never a clamp.
//! - Cost: O(1) per query after an O(patches) build (the ptex map and the f64 points W·cage).
use super::acc2::{CageStencils, GregoryStencils, Tangents};
use crate::error::{Error, Result};
use crate::geom::gregory::{eval_generic, PatchF64};
use crate::mesh::{Cage, NONE};
use glam::DVec3;
use rayon::prelude::*;

/// Where a ptex face's patch comes from.
#[derive(Debug, Clone, Copy)]
enum Ptex {
    /// One patch (a quad of an all-quad cage, or a sub-face of a refined n-gon).
    Patch(u32),
    /// A quad of a refined cage: the patches of its corners 0…3 (`NONE` for holes).
    Quadrants([u32; 4]),
    /// A hole face.
    Hole(u32),
}

/// The surface at (face, u, v): position and exact derivatives with respect to the ptex face's (u, v).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LimitSample {
    pub position: DVec3,
    pub du: DVec3,
    pub dv: DVec3,
    pub duu: DVec3,
    pub duv: DVec3,
    pub dvv: DVec3,
}

/// A cage's limit surface ready for evaluation at arbitrary (face, u, v).
///
/// ```
/// use gregvox::mesh::parse_obj_cage;
/// use gregvox::surface::{LimitEvaluator, Tangents};
/// let plane = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
/// let e = LimitEvaluator::new(&parse_obj_cage(plane, "q.obj").unwrap(), Tangents::OpenSubdiv).unwrap();
/// let s = e.evaluate(&[(0, 0.25, 0.5)]).unwrap();
/// assert!((s[0].position - glam::DVec3::new(0.25, 0.5, 0.0)).length() < 1e-15);
/// assert!(e.evaluate(&[(0, 1.5, 0.0)]).unwrap_err().to_string().contains("row 0"));
/// ```
pub struct LimitEvaluator {
    patches: Vec<PatchF64>,
    ptex: Vec<Ptex>,
}

impl LimitEvaluator {
    /// Builds the stencils of `cage` (see [`GregoryStencils::from_cage`]) and its ptex map.
    pub fn new(cage: &Cage, tangents: Tangents) -> Result<Self> {
        let cs = GregoryStencils::from_cage(cage, tangents)?;
        Self::from_stencils(cage, &cs)
    }

    /// From stencils already built for `cage`.
    pub fn from_stencils(cage: &Cage, cs: &CageStencils) -> Result<Self> {
        let s = &cs.stencils;
        let patches = s.patches_f64(&cage.mesh.positions)?;
        let mesh = &cage.mesh;
        let nf = mesh.n_faces();
        // Patch of each (refined or not) quad face.
        let n_quads = cs.quad_mesh.n_faces();
        let mut patch_of = vec![NONE; n_quads];
        for (k, &f) in s.patch_face.iter().enumerate() {
            patch_of[f as usize] = k as u32;
        }
        let refined = n_quads != nf;
        let mut ptex = Vec::with_capacity(nf);
        let mut corner = 0usize;
        for f in 0..nf {
            let n = mesh.face(f).len();
            if !refined {
                ptex.push(match patch_of[f] {
                    NONE => Ptex::Hole(f as u32),
                    k => Ptex::Patch(k),
                });
            } else if n == 4 {
                let q: [u32; 4] = std::array::from_fn(|i| patch_of[corner + i]);
                ptex.push(if q.iter().all(|&k| k == NONE) {
                    Ptex::Hole(f as u32)
                } else {
                    Ptex::Quadrants(q)
                });
            } else {
                for i in 0..n {
                    ptex.push(match patch_of[corner + i] {
                        NONE => Ptex::Hole(f as u32),
                        k => Ptex::Patch(k),
                    });
                }
            }
            corner += n;
        }
        Ok(LimitEvaluator { patches, ptex })
    }

    /// Number of ptex faces (the valid `face` values are `0..ptex_faces()`).
    pub fn ptex_faces(&self) -> usize {
        self.ptex.len()
    }

    /// The surface at each `(face, u, v)`, in parallel. Errors name the first bad row.
    pub fn evaluate(&self, at: &[(u32, f64, f64)]) -> Result<Vec<LimitSample>> {
        for (row, &(f, u, v)) in at.iter().enumerate() {
            self.locate(row, f, u, v)?;
        }
        Ok(at
            .par_iter()
            .enumerate()
            .map(|(row, &(f, u, v))| self.sample(row, f, u, v).expect("checked above"))
            .collect())
    }

    /// The patch, its (u, v) and the Jacobian d(u', v')/d(u, v) as [[du'/du, du'/dv], [dv'/du, dv'/dv]].
    fn locate(&self, row: usize, f: u32, u: f64, v: f64) -> Result<(u32, f64, f64, [[f64; 2]; 2])> {
        let bad =
            |msg: String| Error::Invalid(format!("row {row} (face {f}, u {u}, v {v}): {msg}"));
        if !(0.0..=1.0).contains(&u) || !(0.0..=1.0).contains(&v) {
            return Err(bad("u and v must lie in [0, 1]".into()));
        }
        let p = *self.ptex.get(f as usize).ok_or_else(|| {
            bad(format!(
                "no such face (the cage has {} ptex faces)",
                self.ptex.len()
            ))
        })?;
        match p {
            Ptex::Hole(face) => Err(bad(format!(
                "cage face {face} is a hole (`t hole`): it has no surface"
            ))),
            Ptex::Patch(k) => Ok((k, u, v, [[1.0, 0.0], [0.0, 1.0]])),
            Ptex::Quadrants(q) => {
                // The child at corner i has (0, 0) at the quad's corner i, u' toward corner i + 1 and v'
                // toward corner i − 1, half the size.
                let (i, uu, vv, j) = match (u >= 0.5, v >= 0.5) {
                    (false, false) => (0, 2.0 * u, 2.0 * v, [[2.0, 0.0], [0.0, 2.0]]),
                    (true, false) => (1, 2.0 * v, 2.0 * (1.0 - u), [[0.0, 2.0], [-2.0, 0.0]]),
                    (true, true) => (
                        2,
                        2.0 * (1.0 - u),
                        2.0 * (1.0 - v),
                        [[-2.0, 0.0], [0.0, -2.0]],
                    ),
                    (false, true) => (3, 2.0 * (1.0 - v), 2.0 * u, [[0.0, -2.0], [2.0, 0.0]]),
                };
                match q[i] {
                    NONE => Err(bad("that part of the face is a hole".into())),
                    k => Ok((k, uu, vv, j)),
                }
            }
        }
    }

    fn sample(&self, row: usize, f: u32, u: f64, v: f64) -> Result<LimitSample> {
        let (k, uu, vv, j) = self.locate(row, f, u, v)?;
        let e = eval_generic(&self.patches[k as usize].cv, uu, vv, true, true);
        let [suu, suv, svv] = e.second;
        // P(u, v) = C(u'(u, v), v'(u, v)), J constant: first derivatives J columns, second JᵀHJ.
        let d = |a: usize| e.su * j[0][a] + e.sv * j[1][a];
        let h = |a: usize, b: usize| {
            suu * (j[0][a] * j[0][b])
                + suv * (j[0][a] * j[1][b] + j[1][a] * j[0][b])
                + svv * (j[1][a] * j[1][b])
        };
        Ok(LimitSample {
            position: e.p,
            du: d(0),
            dv: d(1),
            duu: h(0, 0),
            duv: h(0, 1),
            dvv: h(1, 1),
        })
    }
}
