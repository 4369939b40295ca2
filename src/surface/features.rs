//! Infinitely sharp features and holes of a quad cage, as OpenSubdiv tags them at level 0 (Vtr `VTag`s set
//! by `TopologyRefinerFactoryBase::prepareComponentTagsAndSharpness`) and reads them when it builds patches
//! with `useInfSharpPatch` (`PatchBuilder::IsPatchRegular`, `GetIrregularPatchCornerSpans`).
//!
//! Invariants:
//! - [`Features`] is per [`MeshMatrix`] element: one flag per undirected edge (its edge id), vertex and face.
//!   Boundary edges are infinitely sharp whatever the flags say (Sdc sharpens them under every boundary
//!   rule); a face is a hole if tagged, or, under [`BoundaryInterpolation::None`], if one of its vertices
//!   has a boundary edge not explicitly sharpened (OpenSubdiv's rule, applied before boundaries sharpen).
//! - Only infinite sharpness is represented: semi-sharp tags are refused before ([`SubdivTags::unsupported`])
//!   because they need feature-adaptive isolation.
//! - The vertex rule is Sdc's: a sharp vertex is a corner; otherwise 0 sharp edges smooth, 1 a dart, 2 a
//!   crease, 3 or more a corner. A dart keeps its whole ring (smooth); a crease or corner vertex with sharp
//!   edges cuts its ring into spans at them; a sharp span is a corner (P = v).
//! - Cost: O(corners + tags) per cage; a crease's edge is found by scanning its vertex's row (O(valence)).
//! - An untagged cage ([`Features::none`]) gives exactly the rings, spans and patch types gregvox built
//!   before features existed (boundaries were the only sharp edges).
use crate::error::{Error, Result};
use crate::mesh::{BoundaryInterpolation, MeshMatrix, SubdivTags, NONE, SHARPNESS_INFINITE};

/// Infinitely sharp edges and vertices and hole faces of a cage, indexed as its [`MeshMatrix`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Features {
    /// Per undirected edge (`MeshMatrix` edge id): explicitly infinitely sharp.
    pub sharp_edge: Vec<bool>,
    /// Per vertex: infinitely sharp (a corner).
    pub sharp_vertex: Vec<bool>,
    /// Per face: a hole (no patch).
    pub hole: Vec<bool>,
}

impl Features {
    /// No features: a smooth cage with edge-only boundaries.
    pub fn none(m: &MeshMatrix) -> Self {
        Features {
            sharp_edge: vec![false; m.n_edges()],
            sharp_vertex: vec![false; m.n_verts()],
            hole: vec![false; m.n_faces()],
        }
    }

    /// The features the tags give `m` (the matrix of the tags' mesh). Errors if a tag names an edge,
    /// vertex or face `m` does not have, or if a tag needs what gregvox does not build
    /// ([`SubdivTags::unsupported`] is checked by the caller, which holds the mesh).
    ///
    /// ```
    /// use gregvox::mesh::{parse_obj_cage, MeshMatrix};
    /// use gregvox::surface::Features;
    /// let c = parse_obj_cage("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\n\
    ///                         f 1 2 3 4\nf 2 5 6 3\nt crease 2/1/0 1 2 10\nt interpolateboundary 1/0/0 0\n", "c.obj").unwrap();
    /// let m = MeshMatrix::from_mesh(&c.mesh);
    /// let f = Features::from_tags(&m, &c.tags).unwrap();
    /// assert_eq!(f.sharp_edge.iter().filter(|&&s| s).count(), 1);
    /// assert_eq!(f.hole, [true, true]); // no boundary interpolation: every face touches an unsharpened boundary
    /// ```
    pub fn from_tags(m: &MeshMatrix, tags: &SubdivTags) -> Result<Self> {
        let mut f = Features::none(m);
        for c in &tags.creases {
            let e = m.edge_id(c.a, c.b).ok_or_else(|| {
                Error::Invalid(format!("crease {} {}: not an edge of the cage", c.a, c.b))
            })?;
            // A later tag on the same edge wins, as in OpenSubdiv.
            f.sharp_edge[e] = c.sharpness >= SHARPNESS_INFINITE;
        }
        for c in &tags.corners {
            let v = c.vertex as usize;
            if v >= m.n_verts() {
                return Err(Error::Invalid(format!(
                    "corner {v}: vertex out of range (the cage has {} vertices)",
                    m.n_verts()
                )));
            }
            f.sharp_vertex[v] = c.sharpness >= SHARPNESS_INFINITE;
        }
        for &h in &tags.holes {
            if h as usize >= m.n_faces() {
                return Err(Error::Invalid(format!(
                    "hole {h}: face out of range (the cage has {} faces)",
                    m.n_faces()
                )));
            }
            f.hole[h as usize] = true;
        }
        let twin = m.twins();
        let vc = m.vertex_corners();
        let cv = m.corner_vertex();
        let entry = m.corner_entries();
        match tags.boundary {
            BoundaryInterpolation::EdgeOnly => {}
            BoundaryInterpolation::EdgeAndCorner => {
                // A topological corner (one face, two edges) is sharpened.
                for v in 0..m.n_verts() {
                    if vc.ptr[v + 1] - vc.ptr[v] == 1 {
                        let c = vc.corner[vc.ptr[v] as usize];
                        let out_boundary = twin[entry[c as usize] as usize] == NONE;
                        let p = m.prev(c);
                        let in_boundary = twin[entry[p as usize] as usize] == NONE;
                        if out_boundary && in_boundary {
                            f.sharp_vertex[v] = true;
                        }
                    }
                }
            }
            BoundaryInterpolation::None => {
                // Faces at a vertex with a boundary edge that was not explicitly made infinitely sharp
                // are holes (TopologyRefinerFactoryBase, makeBoundaryFacesHoles).
                let mut exclude = vec![false; m.n_verts()];
                for c in 0..m.n_corners() as u32 {
                    let k = entry[c as usize] as usize;
                    if twin[k] == NONE && !f.sharp_edge[m.half_edge_edge()[k] as usize] {
                        exclude[cv[c as usize] as usize] = true;
                        exclude[cv[m.next(c) as usize] as usize] = true;
                    }
                }
                for c in 0..m.n_corners() {
                    if exclude[cv[c] as usize] {
                        f.hole[m.corner_face()[c] as usize] = true;
                    }
                }
            }
        }
        Ok(f)
    }

    /// The tags' sharpness per `m` edge id and vertex, as OpenSubdiv's level 0 holds it, for features
    /// `self` built by [`Features::from_tags`] from the same tags (which checked every crease edge): the
    /// last tag on an element wins, negative is 0, and a vertex `self` made sharp (a corner tag of 10, or a
    /// topological corner under [`BoundaryInterpolation::EdgeAndCorner`]) is infinitely sharp. Boundary
    /// edges are sharpened by the refinement itself.
    pub fn sharpness(&self, m: &MeshMatrix, tags: &SubdivTags) -> (Vec<f32>, Vec<f32>) {
        let mut edges = vec![0.0f32; m.n_edges()];
        for c in &tags.creases {
            if let Some(e) = m.edge_id(c.a, c.b) {
                edges[e] = c.sharpness.max(0.0);
            }
        }
        let mut verts = vec![0.0f32; m.n_verts()];
        for c in &tags.corners {
            verts[c.vertex as usize] = c.sharpness.max(0.0);
        }
        for (v, &sharp) in self.sharp_vertex.iter().enumerate() {
            if sharp {
                verts[v] = verts[v].max(SHARPNESS_INFINITE);
            }
        }
        (edges, verts)
    }

    /// Errors unless the flags have `m`'s sizes.
    pub(crate) fn check(&self, m: &MeshMatrix) -> Result<()> {
        if self.sharp_edge.len() != m.n_edges()
            || self.sharp_vertex.len() != m.n_verts()
            || self.hole.len() != m.n_faces()
        {
            return Err(Error::Invalid(format!(
                "Gregory stencils: features for {} edges, {} vertices, {} faces; the cage has {}, {}, {}",
                self.sharp_edge.len(),
                self.sharp_vertex.len(),
                self.hole.len(),
                m.n_edges(),
                m.n_verts(),
                m.n_faces()
            )));
        }
        Ok(())
    }

    /// True when nothing is sharp beyond the boundary and no face is a hole.
    pub fn is_none(&self) -> bool {
        !self.sharp_edge.iter().any(|&s| s)
            && !self.sharp_vertex.iter().any(|&s| s)
            && !self.hole.iter().any(|&s| s)
    }
}

/// Sdc's vertex rule from the vertex's sharpness and its count of infinitely sharp edges.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Rule {
    Smooth,
    Dart,
    Crease,
    Corner,
}

/// Per-vertex tags of a manifold quad cage with features (OpenSubdiv's level-0 `VTag`s, those that matter
/// without semi-sharp features).
pub(super) struct VertexTags {
    /// Per corner (half-edge corner → next): its edge is infinitely sharp (boundary or tagged).
    pub sharp_he: Vec<bool>,
    faces: Vec<u32>,
    edges: Vec<u32>,
    sharp_edges: Vec<u32>,
    boundary: Vec<bool>,
    sharp_vertex: Vec<bool>,
}

impl VertexTags {
    /// `twin` is the per-corner twin corner (`NONE` on a boundary).
    pub fn new(m: &MeshMatrix, twin: &[u32], features: &Features) -> Self {
        let nv = m.n_verts();
        let entry = m.corner_entries();
        let he_edge = m.half_edge_edge();
        let cv = m.corner_vertex();
        let sharp_he: Vec<bool> = (0..m.n_corners())
            .map(|c| twin[c] == NONE || features.sharp_edge[he_edge[entry[c] as usize] as usize])
            .collect();
        let (mut faces, mut edges, mut sharp_edges) = (vec![0; nv], vec![0; nv], vec![0; nv]);
        let mut boundary = vec![false; nv];
        for c in 0..m.n_corners() {
            let v = cv[c] as usize;
            faces[v] += 1;
            // Each edge at v once: the outgoing half-edge of every corner, and the incoming one where it
            // has no twin (a boundary edge no corner at v leaves by).
            edges[v] += 1;
            sharp_edges[v] += sharp_he[c] as u32;
            let p = m.prev(c as u32) as usize;
            if twin[p] == NONE {
                edges[v] += 1;
                sharp_edges[v] += 1;
            }
            boundary[v] |= twin[c] == NONE || twin[p] == NONE;
        }
        VertexTags {
            sharp_he,
            faces,
            edges,
            sharp_edges,
            boundary,
            sharp_vertex: features.sharp_vertex.clone(),
        }
    }

    fn rule(&self, v: usize) -> Rule {
        if self.sharp_vertex[v] {
            return Rule::Corner;
        }
        match self.sharp_edges[v] {
            0 => Rule::Smooth,
            1 => Rule::Dart,
            2 => Rule::Crease,
            _ => Rule::Corner,
        }
    }

    /// Whether sharp edges cut v's ring into spans (`testInfSharpEdges`: sharp edges and not a dart).
    pub fn cut(&self, v: usize) -> bool {
        self.sharp_edges[v] > 0 && self.rule(v) != Rule::Dart
    }

    /// Vtr's `_corner`: a topological corner (one face, two edges) that is infinitely sharp.
    fn topological_corner(&self, v: usize) -> bool {
        self.faces[v] == 1 && self.edges[v] == 2 && self.sharp_vertex[v]
    }

    fn xordinary(&self, v: usize) -> bool {
        if self.topological_corner(v) {
            false
        } else if self.boundary[v] {
            self.faces[v] != 2
        } else {
            self.faces[v] != 4
        }
    }

    /// Whether the span of `span_faces` faces at v is sharp (GetIrregularPatchCornerSpans, with the legacy
    /// approxSmoothCornerWithSharp: a smooth boundary corner with one face is sharp).
    pub fn span_is_sharp(&self, v: usize, span_faces: usize) -> bool {
        let sharp = if self.topological_corner(v) {
            true
        } else if self.cut(v) {
            self.rule(v) != Rule::Crease
        } else {
            self.sharp_vertex[v]
        };
        sharp || (self.xordinary(v) && self.boundary[v] && !self.sharp_vertex[v] && span_faces == 1)
    }

    /// PatchBuilder::IsPatchRegular at level 0 for quad face `f`, given the span size of each of its
    /// corners (the faces of the ring `ring_of` built for it).
    pub fn face_is_regular(
        &self,
        m: &MeshMatrix,
        twin: &[u32],
        f: usize,
        span_faces: [usize; 4],
    ) -> bool {
        let cv = m.corner_vertex();
        for (i, &span) in span_faces.iter().enumerate() {
            let c = m.face_start(f) as usize + i;
            let v = cv[c] as usize;
            let xord = self.xordinary(v);
            let sharp_edges = self.sharp_edges[v] > 0;
            let rule = self.rule(v);
            let mut inf_irregular = self.sharp_vertex[v] || sharp_edges;
            if sharp_edges {
                match rule {
                    Rule::Crease if !xord => {
                        // A regular crease runs along a regular boundary or straight through a regular
                        // interior vertex (its two sharp edges opposite: spans of 2 faces each).
                        inf_irregular = !self.boundary[v] && span != 2;
                    }
                    Rule::Corner
                        if self.sharp_edges[v] == self.edges[v]
                            && (self.edges[v] > 2 || self.sharp_vertex[v]) =>
                    {
                        inf_irregular = false;
                    }
                    _ => {}
                }
            }
            if !xord && !inf_irregular {
                continue;
            }
            if xord {
                if !sharp_edges {
                    return false;
                }
                // approxSmoothCornerWithSharp: a smooth boundary corner whose two face edges are boundary.
                let p = m.prev(c as u32) as usize;
                if self.boundary[v] && !self.sharp_vertex[v] && twin[c] == NONE && twin[p] == NONE {
                    continue;
                }
            }
            if inf_irregular {
                if !sharp_edges {
                    return false;
                }
                if rule == Rule::Crease && self.boundary[v] {
                    return false;
                }
                // The span between all sharp edges (a dart's wraps around: all its faces).
                let span = if self.cut(v) {
                    span
                } else {
                    self.faces[v] as usize
                };
                if rule == Rule::Crease {
                    if span != 2 {
                        return false;
                    }
                } else if span != 1 {
                    return false;
                }
            }
        }
        true
    }
}
