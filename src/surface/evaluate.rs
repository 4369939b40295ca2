//! The limit surface at arbitrary parameters: `(face, u, v)` → position, exact first and second
//! derivatives, on the CPU in f64 (OpenSubdiv's `Far::PatchMap` + `EvaluateBasis`, with exact Gregory
//! derivatives where OpenSubdiv's are an approximation).
//!
//! Invariants:
//! - `face` is a ptex face as OpenSubdiv numbers them (`Far::PtexIndices`): the cage's faces in order, a quad
//!   one ptex face, an n-gon (n ≠ 4) n of them, its sub-face i the quad at its corner i with (0, 0) at the
//!   corner's vertex, u toward the midpoint of the next edge and v toward the midpoint of the previous one.
//!   An all-quad cage's ptex faces are its faces.
//! - A cage refined L times ([`crate::surface::GregoryStencils::from_cage`], or only where its features
//!   need it: [`AdaptiveStencils`]; non-quad faces, semi-sharp features) has every
//!   face split into the quads at its corners, level after level: a quad's (u, v) picks the quadrant and is
//!   mapped onto that child's own (u, v) by a rotation and a scale by 2, once per level, and the
//!   derivatives are mapped back by the chain rule (the product of the levels' Jacobians), so they are the
//!   derivatives with respect to the ptex face's own (u, v).
//! - u and v must lie in [0, 1] and be finite; the face must exist and not be a hole: anything else is an
//!   error naming the row, never a clamp.
//! - Cost: O(L) per query after an O(patches) build (the ptex map and the f64 points W·cage).
use super::acc2::{CageStencils, Tangents};
use super::adaptive::{AdaptiveStencils, Node, PatchTree};
use crate::error::{Error, Result};
use crate::geom::gregory::{eval_generic, PatchF64};
use crate::mesh::{Cage, NONE};
use glam::DVec3;
use rayon::prelude::*;

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
    map: PtexMap,
    /// The UV cage's evaluator (same ptex faces and levels: [`crate::surface::fvar`]), when the cage has
    /// UVs.
    uv: Option<Box<LimitEvaluator>>,
}

/// Where each ptex face's surface is: (face, u, v) → (patch, the patch's own (u, v), the Jacobian of that
/// map), by descending the faces' quadtrees ([`PatchTree`]): the uniform layout of
/// [`crate::surface::GregoryStencils::from_cage`] (shared by the CPU evaluator and the device pass,
/// [`crate::passes::patch_at`]) or the feature-adaptive one of [`AdaptiveStencils`].
#[derive(Debug, Clone)]
pub struct PtexMap {
    nodes: Vec<Node>,
    /// The root node of each ptex face.
    ptex: Vec<u32>,
    /// The cage face of each ptex face (for messages).
    ptex_cage_face: Vec<u32>,
}

/// A located query: the patch, its own (u, v), and d(u', v')/d(u, v) as [[du'/du, du'/dv], [dv'/du, dv'/dv]].
pub type Located = (u32, f64, f64, [[f64; 2]; 2]);

impl LimitEvaluator {
    /// Builds the feature-adaptive stencils of `cage` ([`AdaptiveStencils::from_cage`]: the surface of
    /// [`crate::surface::GregoryStencils::from_cage`]'s uniform refinement, with patches only as deep as the features need)
    /// and its ptex map; the UV surface likewise, when the cage has UVs.
    pub fn new(cage: &Cage, tangents: Tangents) -> Result<Self> {
        let a = AdaptiveStencils::from_cage(cage, tangents)?;
        Self::from_adaptive(cage, &a)?.with_uv(cage, a.levels)
    }

    /// This evaluator with the UV surface of `cage` beside it (its UV cage refined feature-adaptively at
    /// the positions' isolation level `levels`, OpenSubdiv's tangent masks); unchanged without UVs.
    pub fn with_uv(mut self, cage: &Cage, levels: u32) -> Result<Self> {
        if let Some(uv_cage) = super::fvar::uv_cage(cage, levels)? {
            let ua = AdaptiveStencils::from_cage(&uv_cage, Tangents::OpenSubdiv)
                .map_err(|e| Error::Invalid(format!("UVs: {e}")))?;
            self.uv = Some(Box::new(Self::from_adaptive(&uv_cage, &ua)?));
        }
        Ok(self)
    }

    /// From feature-adaptive stencils built for `cage` (positions only).
    pub fn from_adaptive(cage: &Cage, a: &AdaptiveStencils) -> Result<Self> {
        Ok(LimitEvaluator {
            patches: a.stencils.patches_f64(&cage.mesh.positions)?,
            map: PtexMap::from_tree(cage, &a.tree),
            uv: None,
        })
    }

    /// Moves the cage this evaluator was built for (with [`Self::from_adaptive`] and stencils `a`) to
    /// `positions`: the patches are recomputed, the ptex map and the UVs (which do not move) kept.
    pub fn set_positions(&mut self, a: &AdaptiveStencils, positions: &[DVec3]) -> Result<()> {
        self.patches = a.stencils.patches_f64(positions)?;
        Ok(())
    }

    /// From stencils already built for `cage` (and, when the cage has UVs, the UV cage's stencils at the
    /// same level, with OpenSubdiv's tangent masks).
    pub fn from_stencils(cage: &Cage, cs: &CageStencils) -> Result<Self> {
        let mut e = Self::positions_only(cage, cs)?;
        if let Some((uv_cage, uv_cs)) = super::fvar::uv_stencils(cage, cs, Tangents::OpenSubdiv)? {
            e.uv = Some(Box::new(Self::positions_only(&uv_cage, &uv_cs)?));
        }
        Ok(e)
    }

    fn positions_only(cage: &Cage, cs: &CageStencils) -> Result<Self> {
        Ok(LimitEvaluator {
            patches: cs.stencils.patches_f64(&cage.mesh.positions)?,
            map: PtexMap::new(cage, cs),
            uv: None,
        })
    }

    /// The ptex map (where each (face, u, v) is).
    pub fn ptex_map(&self) -> &PtexMap {
        &self.map
    }

    /// Number of ptex faces (the valid `face` values are `0..ptex_faces()`).
    pub fn ptex_faces(&self) -> usize {
        self.map.ptex_faces()
    }

    /// Whether the cage has UVs ([`LimitEvaluator::evaluate_uv`]).
    pub fn has_uv(&self) -> bool {
        self.uv.is_some()
    }

    /// The UVs at each `(face, u, v)` (the UV surface's value: OpenSubdiv's face-varying patches), in
    /// parallel; errors as [`LimitEvaluator::evaluate`], and when the cage has no UVs.
    ///
    /// ```
    /// use gregvox::mesh::parse_obj_cage;
    /// use gregvox::surface::{LimitEvaluator, Tangents};
    /// let quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 2 0\nvt 2 2\nvt 0 2\nf 1/1 2/2 3/3 4/4\n";
    /// let e = LimitEvaluator::new(&parse_obj_cage(quad, "q.obj").unwrap(), Tangents::OpenSubdiv).unwrap();
    /// let uv = e.evaluate_uv(&[(0, 0.25, 0.5)]).unwrap();
    /// assert!((uv[0][0] - 0.5).abs() < 1e-15 && (uv[0][1] - 1.0).abs() < 1e-15);
    /// ```
    pub fn evaluate_uv(&self, at: &[(u32, f64, f64)]) -> Result<Vec<[f64; 2]>> {
        let uv = self
            .uv
            .as_ref()
            .ok_or_else(|| Error::Invalid("the cage has no UVs (no `vt` on its faces)".into()))?;
        Ok(uv
            .evaluate_first_order(at)?
            .iter()
            .map(|s| [s.position.x, s.position.y])
            .collect())
    }
}

impl PtexMap {
    /// The map of `cage`'s patches as `cs` (its stencils) lays them out: every face split into the quads
    /// at its corners `cs.levels` times.
    pub fn new(cage: &Cage, cs: &CageStencils) -> Self {
        let s = &cs.stencils;
        let mesh = &cage.mesh;
        let mut patch_of = vec![NONE; cs.quad_mesh.n_faces()];
        for (k, &f) in s.patch_face.iter().enumerate() {
            patch_of[f as usize] = k as u32;
        }
        let leaf = |k: u32| {
            if k == NONE {
                Node::Hole
            } else {
                Node::Patch(k)
            }
        };
        if cs.levels == 0 {
            let nodes = patch_of.into_iter().map(leaf).collect();
            return Self::from_tree(cage, &PatchTree { nodes });
        }
        // Nodes: the cage's faces, then each level's faces in order. Level 1's face c is the quad at cage
        // corner c; below, face q's children are 4q..4q + 4.
        let nf = mesh.n_faces() as u32;
        let mut nodes = Vec::new();
        let mut corner = 0u32;
        for f in 0..nf as usize {
            nodes.push(Node::Split { first: nf + corner });
            corner += mesh.face(f).len() as u32;
        }
        let (mut offset, mut count) = (nf, corner);
        for level in 1..=cs.levels {
            let next = offset + count;
            for q in 0..count {
                nodes.push(if level == cs.levels {
                    leaf(patch_of[q as usize])
                } else {
                    Node::Split {
                        first: next + 4 * q,
                    }
                });
            }
            offset = next;
            count *= 4;
        }
        Self::from_tree(cage, &PatchTree { nodes })
    }

    /// The map of a patch tree of `cage` (node `f` is cage face `f`): a quad is one ptex face, an n-gon's
    /// sub-faces are its children.
    pub fn from_tree(cage: &Cage, tree: &PatchTree) -> Self {
        let mesh = &cage.mesh;
        let mut ptex = Vec::with_capacity(mesh.n_faces());
        let mut ptex_cage_face = Vec::with_capacity(mesh.n_faces());
        for f in 0..mesh.n_faces() {
            let n = mesh.face(f).len() as u32;
            match tree.nodes[f] {
                Node::Split { first } if n != 4 => {
                    ptex.extend(first..first + n);
                    ptex_cage_face.extend(std::iter::repeat_n(f as u32, n as usize));
                }
                // A quad; or an n-gon hole, whose n sub-faces are holes too.
                _ => {
                    let k = if n == 4 { 1 } else { n as usize };
                    ptex.extend(std::iter::repeat_n(f as u32, k));
                    ptex_cage_face.extend(std::iter::repeat_n(f as u32, k));
                }
            }
        }
        PtexMap {
            nodes: tree.nodes.clone(),
            ptex,
            ptex_cage_face,
        }
    }

    /// Number of ptex faces (the valid `face` values are `0..ptex_faces()`).
    pub fn ptex_faces(&self) -> usize {
        self.ptex.len()
    }

    /// Whether ptex face `f` is a hole (no surface). A hole's children are holes, so its first leaf says.
    pub fn is_hole(&self, f: u32) -> bool {
        let mut node = self.ptex[f as usize];
        loop {
            match self.nodes[node as usize] {
                Node::Patch(_) => return false,
                Node::Hole => return true,
                Node::Split { first } => node = first,
            }
        }
    }

    /// Every query located, in parallel; errors name the first bad row (u or v outside [0, 1] or not
    /// finite, no such face, a hole).
    pub fn locate_all(&self, at: &[(u32, f64, f64)]) -> Result<Vec<Located>> {
        let out: Result<Vec<Located>> = at
            .par_iter()
            .enumerate()
            .map(|(row, &(f, u, v))| self.locate(row, f, u, v))
            .collect();
        out.map_err(|e| {
            at.iter()
                .enumerate()
                .find_map(|(row, &(f, u, v))| self.locate(row, f, u, v).err())
                .unwrap_or(e)
        })
    }

    /// The patch, its (u, v) and the Jacobian d(u', v')/d(u, v) as [[du'/du, du'/dv], [dv'/du, dv'/dv]].
    fn locate(&self, row: usize, f: u32, u: f64, v: f64) -> Result<Located> {
        let bad =
            |msg: String| Error::Invalid(format!("row {row} (face {f}, u {u}, v {v}): {msg}"));
        if !(0.0..=1.0).contains(&u) || !(0.0..=1.0).contains(&v) {
            return Err(bad("u and v must lie in [0, 1]".into()));
        }
        self.ptex.get(f as usize).ok_or_else(|| {
            bad(format!(
                "no such face (the cage has {} ptex faces)",
                self.ptex.len()
            ))
        })?;
        let (mut uu, mut vv, mut j) = (u, v, [[1.0, 0.0], [0.0, 1.0]]);
        let descend = |first: u32, uu: &mut f64, vv: &mut f64, j: &mut [[f64; 2]; 2]| -> u32 {
            // The child at corner i has (0, 0) at the quad's corner i, u' toward corner i + 1 and v'
            // toward corner i − 1, half the size: (u', v') = A·(u, v) + b.
            let (i, a, b) = match (*uu >= 0.5, *vv >= 0.5) {
                (false, false) => (0, [[2.0, 0.0], [0.0, 2.0]], [0.0, 0.0]),
                (true, false) => (1, [[0.0, 2.0], [-2.0, 0.0]], [0.0, 2.0]),
                (true, true) => (2, [[-2.0, 0.0], [0.0, -2.0]], [2.0, 2.0]),
                (false, true) => (3, [[0.0, -2.0], [2.0, 0.0]], [2.0, 0.0]),
            };
            let (x, y) = (*uu, *vv);
            *uu = a[0][0] * x + a[0][1] * y + b[0];
            *vv = a[1][0] * x + a[1][1] * y + b[1];
            *j = [
                [
                    a[0][0] * j[0][0] + a[0][1] * j[1][0],
                    a[0][0] * j[0][1] + a[0][1] * j[1][1],
                ],
                [
                    a[1][0] * j[0][0] + a[1][1] * j[1][0],
                    a[1][0] * j[0][1] + a[1][1] * j[1][1],
                ],
            ];
            first + i
        };
        let mut node = self.ptex[f as usize];
        let k = loop {
            match self.nodes[node as usize] {
                Node::Patch(k) => break k,
                Node::Split { first } => node = descend(first, &mut uu, &mut vv, &mut j),
                Node::Hole => {
                    return Err(bad(format!(
                        "cage face {} is a hole (`t hole`): it has no surface there",
                        self.ptex_cage_face[f as usize]
                    )))
                }
            }
        };
        // Rounding in the maps above stays inside [0, 1] (exact for dyadic steps), but clamp anyway.
        Ok((k, uu.clamp(0.0, 1.0), vv.clamp(0.0, 1.0), j))
    }
}

impl LimitEvaluator {
    /// The surface at each `(face, u, v)`, in parallel. Errors name the first bad row.
    pub fn evaluate(&self, at: &[(u32, f64, f64)]) -> Result<Vec<LimitSample>> {
        self.evaluate_with(at, true)
    }

    /// [`LimitEvaluator::evaluate`] without the second derivatives (left zero): position and exact first
    /// derivatives only, what OpenSubdiv's `EvaluateBasis` gives (measured: about a third of the time).
    pub fn evaluate_first_order(&self, at: &[(u32, f64, f64)]) -> Result<Vec<LimitSample>> {
        self.evaluate_with(at, false)
    }

    fn evaluate_with(&self, at: &[(u32, f64, f64)], second: bool) -> Result<Vec<LimitSample>> {
        let out: Result<Vec<LimitSample>> = at
            .par_iter()
            .enumerate()
            .map(|(row, &(f, u, v))| self.sample(row, f, u, v, second))
            .collect();
        // Rayon reports whichever failing row it met first: name the first one in order instead.
        out.map_err(|e| {
            at.iter()
                .enumerate()
                .find_map(|(row, &(f, u, v))| self.map.locate(row, f, u, v).err())
                .unwrap_or(e)
        })
    }

    fn sample(&self, row: usize, f: u32, u: f64, v: f64, second: bool) -> Result<LimitSample> {
        let (k, uu, vv, j) = self.map.locate(row, f, u, v)?;
        let e = eval_generic(&self.patches[k as usize].cv, uu, vv, true, second);
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
