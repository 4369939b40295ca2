//! Feature-adaptive refinement, as OpenSubdiv's `TopologyRefiner::RefineAdaptive(L)` and
//! `PatchTableFactory` build it (`useInfSharpPatch`, Gregory basis end caps): only the faces whose patch
//! would not be the limit surface are refined, level after level, up to the isolation level L; every other
//! face becomes a patch at the level where it first is one. The levels' subdivision matrices are composed
//! into one cage → control-point matrix, as the uniform refinement of [`GregoryStencils::from_cage`] does.
//!
//! Invariants:
//! - A face at level d < L (not a hole) is **split** when OpenSubdiv's `doesFaceHaveFeatures` selects it
//!   (`face_has_features`, Vtr's vertex tags computed afresh at each level): not a quad, or a vertex
//!   touching a non-quad face, an extraordinary vertex, a semi-sharp vertex or edge at one of its vertices
//!   (0 < s < 10 at this level), an irregular infinitely sharp feature (`useInfSharpPatch`), or a boundary
//!   extraordinary vertex (which `IsPatchRegular` alone would pass as a legacy sharp corner). Otherwise it
//!   is a **leaf**: a B-spline patch at level d, whose surface
//!   equals its descendants' (B-spline refinement is exact), so the surface is that of the uniform
//!   refinement to L (tested point for point). At level L every face left is a patch (Gregory end caps at
//!   the irregular ones). Holes are never split and have no patch. A level's Gregory stencils are built for
//!   its leaves alone (a split face's patch would be discarded: about half the candidates on a creased cage).
//! - Level d + 1 refines only `S_d`, the faces sharing a vertex with a split face, with Sdc's rules
//!   ([`crate::mesh::catmull_clark_matrix_creased`]). The refined part has a fringe whose points are wrong
//!   (their rings are cut), but no point a patch or a further level reads lies there: the children of a
//!   split face read the vertex points of its vertices, the edge points of the edges at them and the face
//!   points of the faces around them, all of which `S_d` holds whole (docs/dev-surface.md, "Feature-adaptive
//!   refinement").
//! - The result is a quadtree per ptex face ([`PatchTree`]): a split face's children are the quads at its
//!   corners, child i at corner i, numbered consecutively, as [`crate::surface::PtexMap`] descends them.
//! - Cost: O(corners) at level 0, then per level the faces around the features: a point feature (an
//!   extraordinary vertex, a corner) keeps a constant number of faces per level, a crease curve doubles
//!   its faces per level (its length in faces doubles as they halve), so O(corners + points·L + crease
//!   edges·2^L), against the uniform refinement's O(corners·4^L). Each face's rows are composed down to
//!   the cage (a level-L vertex depends on a bounded neighbourhood of cage vertices: tens of entries).
//!   Measured (release, 2 cores): OpenSubdiv's `catmark_car` (1,575 quads, 314 creases of sharpness 6)
//!   at L = 6 makes 136 k patches in ~1.4 s and 0.58 GB (~2 s while split faces' patches were built
//!   too), where the uniform refinement would make 6.4 M; a 64² grid with a crease polyline of 9.5 at
//!   L = 10 makes 275 k patches in ~4 s (uniform: 4·10⁹).
//!   Attacking input: a 64² grid whose every interior edge is a crease of 9.5 grows by ~2× per level
//!   everywhere and is refused past [`MAX_ADAPTIVE_PATCHES`] (patches made plus the next level's faces)
//!   before that level is built: after ~4–11 s and a 2 GB peak (tests/surface_adaptive.rs).
use super::acc2::{
    cage_features, check_manifold_and_oriented, isolation, twin_corners, GregoryStencils, Tangents,
};
use super::features::Features;
use crate::error::{Error, Result};
use crate::mesh::{
    catmull_clark_matrix_creased_hidden, Cage, MeshMatrix, SparseMatrix, SHARPNESS_INFINITE,
};

/// The most patches (and split faces) feature-adaptive refinement may make.
pub const MAX_ADAPTIVE_PATCHES: usize = 1 << 20;

/// One node of a ptex face's quadtree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Node {
    /// The surface here is this patch.
    Patch(u32),
    /// A hole: no surface.
    Hole,
    /// Refined: the children are nodes `first..first + n` (n the face's corner count: 4 below the cage),
    /// child i the quad at corner i ((0, 0) at the corner, u toward the next corner).
    Split { first: u32 },
}

/// The quadtrees of the cage's faces: node `f` is cage face `f`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PatchTree {
    pub nodes: Vec<Node>,
}

/// Stencils built by feature-adaptive refinement.
#[derive(Clone, Debug)]
pub struct AdaptiveStencils {
    /// The control-point rows over the cage's vertices and the patches; `patch_face[k]` is patch k's cage
    /// face, `regular[k]` whether it is a B-spline patch.
    pub stencils: GregoryStencils,
    /// Per patch: its refinement level (0 = a cage face).
    pub depth: Vec<u8>,
    pub tree: PatchTree,
    /// The isolation level L.
    pub levels: u32,
    /// Faces split at each level (the refined faces are 4 times as many).
    pub split_per_level: Vec<usize>,
}

/// One level of the refinement: its mesh, the rows of its vertices over the cage's, and its tags.
struct Level {
    m: MeshMatrix,
    x: SparseMatrix<f64>,
    edge_sharpness: Vec<f32>,
    vertex_sharpness: Vec<f32>,
    hole: Vec<bool>,
    /// Per vertex, hidden semi-sharp edges (UV cages under Chaikin: `SubdivTags::hidden_semi_sharp`).
    hidden: Vec<Vec<f32>>,
}

impl Level {
    /// The next level: the Catmull–Clark refinement (Sdc's crease rules) of `S`, the faces sharing a vertex
    /// with a face of `split`, as a mesh of its own (the module doc says why its fringe is never read);
    /// and per split face, its first child face and its child count (one quad per corner, consecutive).
    fn refine_around(&self, split: &[u32], chaikin: bool) -> Result<(Level, Vec<(u32, u32)>)> {
        let m = &self.m;
        let nf = m.n_faces();
        let vc = m.vertex_corners();
        let cf = m.corner_face();
        let mut in_s = vec![false; nf];
        for &f in split {
            for &v in m.face(f as usize) {
                for k in vc.ptr[v as usize]..vc.ptr[v as usize + 1] {
                    in_s[cf[vc.corner[k as usize] as usize] as usize] = true;
                }
            }
        }
        let s_faces: Vec<u32> = (0..nf as u32).filter(|&f| in_s[f as usize]).collect();
        let mut local = vec![u32::MAX; m.n_verts()];
        let mut verts: Vec<u32> = Vec::new();
        let mut face_ptr = vec![0u32];
        let mut corner_vertex = Vec::new();
        for &f in &s_faces {
            for &v in m.face(f as usize) {
                if local[v as usize] == u32::MAX {
                    local[v as usize] = verts.len() as u32;
                    verts.push(v);
                }
                corner_vertex.push(local[v as usize]);
            }
            face_ptr.push(corner_vertex.len() as u32);
        }
        let sub = MeshMatrix::new(verts.len() as u32, &face_ptr, corner_vertex)?;
        let sub_edges: Vec<f32> = (0..sub.n_edges())
            .map(|e| {
                let [a, b] = sub.edge_vertices(e);
                m.edge_id(verts[a as usize], verts[b as usize])
                    .map_or(0.0, |pe| self.edge_sharpness[pe])
            })
            .collect();
        let sub_verts: Vec<f32> = verts
            .iter()
            .map(|&v| self.vertex_sharpness[v as usize])
            .collect();
        let sub_hidden: Vec<Vec<f32>> = if self.hidden.is_empty() {
            Vec::new()
        } else {
            verts
                .iter()
                .map(|&v| self.hidden[v as usize].clone())
                .collect()
        };
        let c =
            catmull_clark_matrix_creased_hidden(&sub, &sub_edges, &sub_verts, chaikin, &sub_hidden);
        // Refined face k is the quad at corner k of `sub`, a hole if its face is.
        let hole: Vec<bool> = sub
            .corner_face()
            .iter()
            .map(|&lf| self.hole[s_faces[lf as usize] as usize])
            .collect();
        let mut local_face = vec![u32::MAX; nf];
        for (lf, &f) in s_faces.iter().enumerate() {
            local_face[f as usize] = lf as u32;
        }
        let children = split
            .iter()
            .map(|&f| {
                let lf = local_face[f as usize] as usize;
                (sub.face_start(lf), sub.face_len(lf))
            })
            .collect();
        let next = Level {
            x: c.sub.s.matmul(&gather_rows(&self.x, &verts)),
            m: c.sub.topology,
            edge_sharpness: c.edge_sharpness,
            vertex_sharpness: c.vertex_sharpness,
            hole,
            hidden: c.hidden,
        };
        Ok((next, children))
    }

    fn features(&self) -> Features {
        Features {
            sharp_edge: self
                .edge_sharpness
                .iter()
                .map(|&s| s >= SHARPNESS_INFINITE)
                .collect(),
            sharp_vertex: self
                .vertex_sharpness
                .iter()
                .map(|&s| s >= SHARPNESS_INFINITE)
                .collect(),
            hole: self.hole.clone(),
        }
    }
}

/// Sdc's vertex rules as bits, as Vtr ORs them over a face's corners.
const RULE_SMOOTH: u8 = 1;
const RULE_DART: u8 = 2;
const RULE_CREASE: u8 = 4;
const RULE_CORNER: u8 = 8;

/// Vtr's `Level::VTag`, the bits feature selection reads (`TopologyRefinerFactoryBase::
/// prepareComponentTagsAndSharpness`), computed afresh at each level from its topology and sharpness.
#[derive(Clone, Copy, Default)]
struct VTag {
    rule: u8,
    boundary: bool,
    corner: bool,
    xordinary: bool,
    inf_sharp: bool,
    inf_sharp_edges: bool,
    inf_irregular: bool,
    semi_sharp: bool,
    semi_sharp_edges: bool,
    incid_irreg_face: bool,
}

impl VTag {
    fn or(self, o: VTag) -> VTag {
        VTag {
            rule: self.rule | o.rule,
            boundary: self.boundary | o.boundary,
            corner: self.corner | o.corner,
            xordinary: self.xordinary | o.xordinary,
            inf_sharp: self.inf_sharp | o.inf_sharp,
            inf_sharp_edges: self.inf_sharp_edges | o.inf_sharp_edges,
            inf_irregular: self.inf_irregular | o.inf_irregular,
            semi_sharp: self.semi_sharp | o.semi_sharp,
            semi_sharp_edges: self.semi_sharp_edges | o.semi_sharp_edges,
            incid_irreg_face: self.incid_irreg_face | o.incid_irreg_face,
        }
    }

    /// `doesInfSharpVTagHaveFeatures` with `useInfSharpPatch` (regular creases and corners unselected).
    fn inf_sharp_features(self) -> bool {
        self.inf_irregular && self.rule & (RULE_CORNER | RULE_CREASE | RULE_DART) != 0
    }
}

/// Sdc's `DetermineVertexVertexRule`.
fn vertex_rule(sharpness: f32, sharp_edges: usize) -> u8 {
    if sharpness > 0.0 {
        return RULE_CORNER;
    }
    match sharp_edges {
        0 => RULE_SMOOTH,
        1 => RULE_DART,
        2 => RULE_CREASE,
        _ => RULE_CORNER,
    }
}

/// The tags of the vertices of `faces` (others default).
fn vertex_tags(
    level: &Level,
    faces: &[u32],
    edges: &[Vec<u32>],
    touches_nonquad: &[bool],
) -> Vec<VTag> {
    let m = &level.m;
    let uses = m.edge_uses();
    let twin = twin_corners(m);
    let entry = m.corner_entries();
    let he_edge = m.half_edge_edge();
    let vc = m.vertex_corners();
    let mut tags = vec![VTag::default(); m.n_verts()];
    let mut done = vec![false; m.n_verts()];
    for &f in faces {
        for &v in m.face(f as usize) {
            let vu = v as usize;
            if std::mem::replace(&mut done[vu], true) {
                continue;
            }
            let n_faces = (vc.ptr[vu + 1] - vc.ptr[vu]) as usize;
            let n_edges = edges[vu].len();
            let boundary_edge = |e: u32| uses[e as usize].faces() != 2;
            let inf_edge =
                |e: u32| boundary_edge(e) || level.edge_sharpness[e as usize] >= SHARPNESS_INFINITE;
            let semi_edge = |e: u32| !inf_edge(e) && level.edge_sharpness[e as usize] > 0.0;
            let n_boundary = edges[vu].iter().filter(|&&e| boundary_edge(e)).count();
            let n_inf = edges[vu].iter().filter(|&&e| inf_edge(e)).count();
            let n_semi = edges[vu].iter().filter(|&&e| semi_edge(e)).count();
            let vs = level.vertex_sharpness[vu];
            let mut t = VTag {
                inf_sharp: vs >= SHARPNESS_INFINITE,
                semi_sharp: vs > 0.0 && vs < SHARPNESS_INFINITE,
                semi_sharp_edges: n_semi > 0,
                rule: vertex_rule(vs, n_inf + n_semi),
                boundary: n_boundary > 0,
                incid_irreg_face: touches_nonquad[vu],
                ..VTag::default()
            };
            t.corner = n_faces == 1 && n_edges == 2 && t.inf_sharp;
            t.xordinary = !t.corner && n_faces != if t.boundary { 2 } else { 4 };
            t.inf_sharp_edges = n_inf > 0;
            t.inf_irregular = t.inf_sharp || t.inf_sharp_edges;
            if t.inf_sharp_edges {
                match vertex_rule(if t.inf_sharp { vs } else { 0.0 }, n_inf) {
                    RULE_CREASE if !t.xordinary => {
                        t.inf_irregular = !t.boundary && {
                            // A regular interior crease bisects the ring: its two sharp edges are
                            // opposite (edges 0 and 2 around the vertex both sharp or both smooth).
                            let c0 = vc.corner[vc.ptr[vu] as usize];
                            let c2 = twin[m.prev(twin[m.prev(c0) as usize]) as usize];
                            let out = |c: u32| he_edge[entry[c as usize] as usize];
                            inf_edge(out(c0)) != inf_edge(out(c2))
                        };
                    }
                    RULE_CORNER if n_inf == n_edges && (n_edges > 2 || t.inf_sharp) => {
                        t.inf_irregular = false;
                    }
                    _ => {}
                }
            }
            tags[vu] = t;
        }
    }
    tags
}

/// `doesFaceHaveFeatures` (Far/topologyRefiner.cpp) for a complete face with OpenSubdiv's default
/// adaptive options (`useInfSharpPatch`, no single-crease patch, the secondary level past L): whether
/// feature-adaptive refinement selects it.
fn face_has_features(m: &MeshMatrix, f: usize, tags: &[VTag], depth: u32) -> bool {
    let face = m.face(f);
    if face.len() != 4 {
        return true;
    }
    let t: Vec<VTag> = face.iter().map(|&v| tags[v as usize]).collect();
    let comp = t.iter().fold(VTag::default(), |a, &b| a.or(b));
    if comp.incid_irreg_face {
        return true;
    }
    if comp.xordinary {
        if comp.rule == RULE_SMOOTH {
            return true;
        }
        if depth < 2 && t.iter().any(|x| x.xordinary && x.rule == RULE_SMOOTH) {
            return true;
        }
    }
    if comp.rule == RULE_SMOOTH {
        return false;
    }
    if comp.semi_sharp || comp.semi_sharp_edges {
        return true;
    }
    if comp.inf_sharp || comp.inf_sharp_edges {
        if comp.rule & RULE_SMOOTH != 0 {
            return comp.inf_sharp_features();
        }
        return t
            .iter()
            .any(|x| x.rule & RULE_SMOOTH == 0 && x.inf_sharp_features());
    }
    false
}

/// The undirected edges at each vertex (edge ids).
fn edges_at(m: &MeshMatrix) -> Vec<Vec<u32>> {
    let mut out = vec![Vec::new(); m.n_verts()];
    for e in 0..m.n_edges() {
        let [a, b] = m.edge_vertices(e);
        out[a as usize].push(e as u32);
        out[b as usize].push(e as u32);
    }
    out
}

/// The rows `rows` of `x`, in that order.
fn gather_rows(x: &SparseMatrix<f64>, rows: &[u32]) -> SparseMatrix<f64> {
    let mut row_ptr = Vec::with_capacity(rows.len() + 1);
    row_ptr.push(0u32);
    let nnz: usize = rows.iter().map(|&r| x.row(r as usize).0.len()).sum();
    let (mut col, mut val) = (Vec::with_capacity(nnz), Vec::with_capacity(nnz));
    for &r in rows {
        let (c, v) = x.row(r as usize);
        col.extend_from_slice(c);
        val.extend_from_slice(v);
        row_ptr.push(col.len() as u32);
    }
    SparseMatrix {
        n_rows: rows.len() as u32,
        n_cols: x.n_cols,
        row_ptr,
        col,
        val,
    }
}

fn identity(n: usize) -> SparseMatrix<f64> {
    SparseMatrix {
        n_rows: n as u32,
        n_cols: n as u32,
        row_ptr: (0..=n as u32).collect(),
        col: (0..n as u32).collect(),
        val: vec![1.0; n],
    }
}

impl AdaptiveStencils {
    /// The feature-adaptive stencils of a tagged cage at its isolation level (⌈largest semi-sharp
    /// sharpness⌉, 1 with non-quad faces, or `--isolation`). An untagged all-quad cage is one level of
    /// leaves: [`GregoryStencils::from_mesh`]'s patches. Errors: what [`GregoryStencils::from_cage`]
    /// refuses, except the uniform refinement's patch limit; past [`MAX_ADAPTIVE_PATCHES`].
    ///
    /// ```
    /// use gregvox::mesh::parse_obj_cage;
    /// use gregvox::surface::adaptive::AdaptiveStencils;
    /// use gregvox::surface::Tangents;
    /// // A 4×4 grid of quads with one semi-sharp crease of 3 on an inner edge: only the faces around the
    /// // crease are refined, three times.
    /// let mut obj = String::new();
    /// for j in 0..5 { for i in 0..5 { obj += &format!("v {i} {j} 0\n"); } }
    /// for j in 0..4 { for i in 0..4 { let a = j * 5 + i + 1; obj += &format!("f {} {} {} {}\n", a, a + 1, a + 6, a + 5); } }
    /// obj += "t crease 2/1/0 11 12 3\n";
    /// let a = AdaptiveStencils::from_cage(&parse_obj_cage(&obj, "g.obj").unwrap(), Tangents::OpenSubdiv).unwrap();
    /// assert_eq!(a.levels, 3);
    /// assert!(a.stencils.patch_points.len() < 16 * 64); // the uniform refinement's count
    /// assert_eq!(*a.depth.iter().max().unwrap(), 3);
    /// ```
    pub fn from_cage(cage: &Cage, tangents: Tangents) -> Result<AdaptiveStencils> {
        let (m, features) = cage_features(cage)?;
        // Without tags a non-quad cage is refined once (GregoryStencils::from_mesh).
        let all_quads = (0..m.n_faces()).all(|f| m.face_len(f) == 4);
        let levels = isolation(cage, &m, &features)?.map_or(!all_quads as u32, |i| i.levels);
        check_manifold_and_oriented(&m)?;
        let (edge_sharpness, vertex_sharpness) = features.sharpness(&m, &cage.tags);
        let nv = m.n_verts();
        let nf0 = m.n_faces();
        let mut level = Level {
            x: identity(nv),
            edge_sharpness,
            vertex_sharpness,
            hole: features.hole.clone(),
            m,
            hidden: cage.tags.hidden_semi_sharp.clone(),
        };
        let chaikin = cage.tags.chaikin;

        let mut nodes: Vec<Node> = vec![Node::Hole; nf0];
        // The faces of this level that have complete rings: (face, node, cage face).
        let mut candidates: Vec<(u32, u32, u32)> = (0..nf0 as u32).map(|f| (f, f, f)).collect();
        let mut blocks: Vec<SparseMatrix<f64>> = Vec::new();
        let mut n_rows = 0u32;
        let (mut patch_points, mut regular, mut patch_face, mut depth) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut split_per_level = Vec::new();
        for d in 0..=levels {
            let m = &level.m;
            let nf = m.n_faces();
            // Level 0 may hold non-quad faces: a quad touching one has an irregular ring.
            let mut touches_nonquad = vec![false; m.n_verts()];
            for f in (0..nf).filter(|&f| m.face_len(f) != 4) {
                for &v in m.face(f) {
                    touches_nonquad[v as usize] = true;
                }
            }
            let mut eligible = vec![false; nf];
            for &(f, _, _) in &candidates {
                let f = f as usize;
                eligible[f] = !level.hole[f]
                    && m.face_len(f) == 4
                    && !m.face(f).iter().any(|&v| touches_nonquad[v as usize]);
            }
            let edges = edges_at(m);
            let cand_faces: Vec<u32> = candidates.iter().map(|c| c.0).collect();
            let tags = vertex_tags(&level, &cand_faces, &edges, &touches_nonquad);
            let mut split: Vec<(u32, u32, u32)> = Vec::new();
            let mut leaves: Vec<(u32, u32, u32)> = Vec::new();
            for &(f, node, base) in &candidates {
                let fu = f as usize;
                if level.hole[fu] {
                    nodes[node as usize] = Node::Hole;
                    continue;
                }
                if d < levels && face_has_features(m, fu, &tags, d) {
                    split.push((f, node, base));
                } else if !eligible[fu] {
                    return Err(Error::Invalid(format!(
                        "Gregory stencils: face {f} at level {d} is not a quad with complete rings"
                    )));
                } else {
                    leaves.push((f, node, base));
                }
            }
            // Patches for the leaves alone: a face split here has its patches at the levels below (about
            // half of each level's candidates on a creased cage).
            let mut is_leaf = vec![false; nf];
            for &(f, _, _) in &leaves {
                is_leaf[f as usize] = true;
            }
            let built =
                GregoryStencils::with_features_on(m, &level.features(), tangents, &is_leaf)?;
            let mut patch_of = vec![u32::MAX; nf];
            for (k, &f) in built.patch_face.iter().enumerate() {
                patch_of[f as usize] = k as u32;
            }
            // The leaves' patches: their rows (only those they reference), composed down to the cage.
            let mut row_new = vec![u32::MAX; built.w.n_rows as usize];
            let mut used: Vec<u32> = Vec::new();
            for &(f, node, base) in &leaves {
                let k = patch_of[f as usize] as usize;
                let pp = built.patch_points[k].map(|r| {
                    if row_new[r as usize] == u32::MAX {
                        row_new[r as usize] = used.len() as u32;
                        used.push(r);
                    }
                    n_rows + row_new[r as usize]
                });
                nodes[node as usize] = Node::Patch(patch_points.len() as u32);
                patch_points.push(pp);
                regular.push(built.regular[k]);
                patch_face.push(base);
                depth.push(d as u8);
            }
            if !used.is_empty() {
                blocks.push(gather_rows(&built.w, &used).matmul(&level.x));
                n_rows += used.len() as u32;
            }
            if patch_points.len() + 4 * split.len() > MAX_ADAPTIVE_PATCHES {
                return Err(Error::Invalid(format!(
                    "feature-adaptive refinement: level {} would hold {} faces beside {} patches, past the \
                     limit of {MAX_ADAPTIVE_PATCHES}: lower the sharpness or the isolation level",
                    d + 1,
                    4 * split.len(),
                    patch_points.len()
                )));
            }
            split_per_level.push(split.len());
            if split.is_empty() {
                break;
            }
            let faces: Vec<u32> = split.iter().map(|s| s.0).collect();
            let (refined, children) = level.refine_around(&faces, chaikin)?;
            let mut next = Vec::with_capacity(4 * split.len());
            for (&(_, node, base), &(child, n)) in split.iter().zip(&children) {
                let first = nodes.len() as u32;
                nodes[node as usize] = Node::Split { first };
                for i in 0..n {
                    nodes.push(Node::Hole);
                    next.push((child + i, first + i, base));
                }
            }
            level = refined;
            candidates = next;
        }
        // One matrix: the levels' blocks stacked.
        // Sized once (the car's is 16 M entries, 200 MB, which growing by doubling copied twice over).
        let nnz: usize = blocks.iter().map(|b| b.col.len()).sum();
        let mut row_ptr = Vec::with_capacity(n_rows as usize + 1);
        row_ptr.push(0u32);
        let mut w = SparseMatrix {
            n_rows,
            n_cols: nv as u32,
            row_ptr,
            col: Vec::with_capacity(nnz),
            val: Vec::with_capacity(nnz),
        };
        for b in blocks {
            let base = *w.row_ptr.last().expect("row_ptr starts at 0");
            w.row_ptr.extend(b.row_ptr[1..].iter().map(|&p| base + p));
            w.col.extend(b.col);
            w.val.extend(b.val);
        }
        Ok(AdaptiveStencils {
            stencils: GregoryStencils {
                w,
                patch_points,
                regular,
                patch_face,
            },
            depth,
            tree: PatchTree { nodes },
            levels,
            split_per_level,
        })
    }
}
