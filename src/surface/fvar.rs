//! Face-varying UVs as a surface of their own: the cage's UVs become a second cage (the **UV cage**) whose
//! vertices are the UV values, whose faces are the cage's faces in the same order, and whose tags say what
//! OpenSubdiv's face-varying rules say (Vtr `FVarLevel::completeTopologyFromFaceValues`). Its Gregory
//! stencils, built exactly like the positions' ([`GregoryStencils::from_cage`]) at the same refinement
//! level, give one UV patch per position patch, in the same order and parameterization, so every
//! evaluator (the GPU tessellation, [`crate::surface::LimitEvaluator`]) evaluates UVs by evaluating the UV
//! cage's surface at the same (patch, u, v).
//!
//! Invariants:
//! - A UV-cage vertex is one **span**: the corners of one cage vertex with the same value, connected across
//!   continuous edges (an edge is continuous when both its faces give both its ends the same values). A
//!   seam (a discontinuous edge) is therefore a boundary of the UV cage, as OpenSubdiv treats it; a value
//!   used by two disjoint spans around a vertex (a "bowtie" in UV space) is two UV-cage vertices with the
//!   same value, each an infinitely sharp corner (OpenSubdiv tags such values non-manifold, and sharp).
//! - The UV cage inherits the cage's creases (on continuous edges), vertex sharpness (on every span of the
//!   vertex, including the topological corners of `interpolateboundary 1`), holes (including the faces
//!   `interpolateboundary 0` drops) and creasing method; its boundary rule is edge-only, and the
//!   [`FVarLinear`] rule adds infinitely sharp corners as `FVarLevel` does at a vertex whose UV topology
//!   differs from its vertex topology ("mismatch"): a span of one face (every rule but `None`); every span
//!   of a vertex with more than two values (`CornersPlus1`, `CornersPlus2`) or with two values of which one
//!   has an interior infinitely sharp edge (or, `CornersPlus2`, a single face); darts (`CornersPlus2`,
//!   `Boundaries`); every span at a seam or boundary (`Boundaries`). `All` makes every edge and vertex
//!   infinitely sharp, which is bilinear subdivision, and its patches bilinear.
//! - Dependent sharpness (`CornersPlus1/2`, Vtr's `_depSharp`): at a vertex with two values of which only
//!   one span has semi-sharp interior edges, OpenSubdiv keeps the other value a corner until those decay,
//!   then blends it with their fractional weight. The other span gets the vertex sharpness that does the
//!   same ([`crate::mesh::dependent_vertex_sharpness`]: the leader's edges decayed as the cage decays them,
//!   uniform or Chaikin; a vertex decays by one a level): exact against OpenSubdiv (tests/surface_uv.rs).
//! - Chaikin creasing averages a crease's decay over every semi-sharp edge of its *cage* vertex, while a
//!   span's UV-cage vertex has only its own edges: the others (the seam's, the other spans') ride along as
//!   its hidden edges ([`SubdivTags::hidden_semi_sharp`], refined by
//!   [`crate::mesh::catmull_clark_matrix_creased_hidden`]), so the UV cage's creases decay as the cage's do.
//! - Cost: O(corners) over the cage's [`MeshMatrix`] (twins, one union–find); the stencils cost what the positions' do
//!   (the UV cage has at most one vertex per corner and the same faces). Its attacking input is a UV soup,
//!   every face its own island (unwelded exports): a seam at every edge, four UV-cage vertices per face,
//!   each a sharp corner, so every UV patch is the bilinear map of its face's values
//!   (tests/surface_uv.rs, 64² faces: 2.8 ms for the UV cage against 19 ms for the positions' stencils).
use super::acc2::{CageStencils, GregoryStencils, Tangents};
use super::features::Features;
use crate::error::{Error, Result};
use crate::mesh::{
    dependent_vertex_sharpness, BoundaryInterpolation, Cage, CornerTag, Crease, FVarLinear, Mesh,
    MeshMatrix, SubdivTags, NONE, SHARPNESS_INFINITE,
};
use glam::DVec3;

/// Union–find over corners, with path halving.
fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let p = parent[parent[x as usize] as usize];
        parent[x as usize] = p;
        x = p;
    }
    x
}

/// The UV cage of `cage` (module doc), or `None` when the cage has no UVs. `levels` is the refinement
/// level of the positions' stencils ([`CageStencils::levels`]), which the UV cage is asked to use too.
///
/// ```
/// use gregvox::mesh::parse_obj_cage;
/// use gregvox::surface::fvar::uv_cage;
/// // Two quads with a seam between them: the shared edge has different UVs on its two sides.
/// let text = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nv 1 1 0\nv 2 1 0\n\
///             vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 2 0\nvt 3 0\nvt 3 1\nvt 2 1\n\
///             f 1/1 2/2 5/3 4/4\nf 2/5 3/6 6/7 5/8\n";
/// let cage = parse_obj_cage(text, "seam.obj").unwrap();
/// let uv = uv_cage(&cage, 0).unwrap().unwrap();
/// assert_eq!(uv.mesh.positions.len(), 8); // the seam splits vertices 2 and 5 in two
/// assert_eq!(uv.tags.corners.len(), 8); // every span has one face: UV corners (Corners Only)
/// ```
pub fn uv_cage(cage: &Cage, levels: u32) -> Result<Option<Cage>> {
    let Some(uv) = &cage.uv else {
        return Ok(None);
    };
    let mesh = &cage.mesh;
    let n_corners = mesh.indices.len();
    if uv.indices.len() != n_corners {
        return Err(Error::Invalid(format!(
            "UVs: {} value indices for {} face corners",
            uv.indices.len(),
            n_corners
        )));
    }
    let m = MeshMatrix::from_mesh(mesh);
    let features = Features::from_tags(&m, &cage.tags)?;
    let (edge_s, vert_s) = features.sharpness(&m, &cage.tags);
    let rule = cage.tags.fvar_linear();
    // The cage's corners are the matrix's corners; a corner's outgoing half-edge and its twin come from
    // the matrix (the twin's corner is the other face's corner at this edge's head).
    let twin = m.twins();
    let entry = m.corner_entries();
    let entry_corner = &m.vertex_corners().corner;
    let he_edge = m.half_edge_edge();
    let val = |c: u32| uv.indices[c as usize];
    let vtx = |c: u32| mesh.indices[c as usize];
    let mut parent: Vec<u32> = (0..n_corners as u32).collect();
    let mut mismatch = vec![false; mesh.positions.len()];
    let mut boundary = vec![false; mesh.positions.len()];
    // Continuous interior edges: (corner at a, corner at b) of one face, for the creases.
    let mut continuous: Vec<(u32, u32, f32)> = Vec::new();
    for c in 0..n_corners as u32 {
        let cn = m.next(c);
        let (a, b) = (vtx(c), vtx(cn));
        let k = entry[c as usize] as usize;
        if twin[k] == NONE {
            boundary[a as usize] = true;
            boundary[b as usize] = true;
            continue;
        }
        // t: b→a in the other face; its next corner tn is that face's corner at a. Each undirected edge
        // once, from its lower-numbered corner.
        let t = entry_corner[twin[k] as usize];
        if t < c {
            continue;
        }
        let tn = m.next(t);
        if val(c) == val(tn) && val(cn) == val(t) {
            let (ra, rb) = (find(&mut parent, c), find(&mut parent, tn));
            parent[ra as usize] = rb;
            let (ra, rb) = (find(&mut parent, cn), find(&mut parent, t));
            parent[ra as usize] = rb;
            continuous.push((c, cn, edge_s[he_edge[k] as usize]));
        } else {
            mismatch[a as usize] = true;
            mismatch[b as usize] = true;
        }
    }
    // Spans: number the classes in order of first corner.
    let mut span_of = vec![u32::MAX; n_corners];
    let mut root_span = vec![u32::MAX; n_corners];
    let mut span_value: Vec<u32> = Vec::new();
    let mut span_vertex: Vec<u32> = Vec::new();
    let mut span_faces: Vec<u32> = Vec::new();
    for c in 0..n_corners as u32 {
        let r = find(&mut parent, c);
        let next_id = span_value.len() as u32;
        if root_span[r as usize] == u32::MAX {
            root_span[r as usize] = next_id;
        }
        let s = root_span[r as usize];
        if s == next_id {
            span_value.push(val(c));
            span_vertex.push(vtx(c));
            span_faces.push(0);
        }
        span_faces[s as usize] += 1;
        span_of[c as usize] = s;
    }
    let n_spans = span_value.len();
    // Per vertex: its spans, and per span whether its value has another span at the vertex (disjoint).
    let mut vertex_spans: Vec<Vec<u32>> = vec![Vec::new(); mesh.positions.len()];
    for s in 0..n_spans {
        vertex_spans[span_vertex[s] as usize].push(s as u32);
    }
    // Semi-sharp edges (0 < s < ∞): per vertex every one (each edge once: Chaikin averages over all of
    // them), per span its interior ones (dependent sharpness, below).
    let semi_sharp = |s: f32| s > 0.0 && s < SHARPNESS_INFINITE;
    let mut semi_list: Vec<Vec<f32>> = vec![Vec::new(); mesh.positions.len()];
    for c in 0..n_corners as u32 {
        let k = entry[c as usize] as usize;
        if twin[k] != NONE && entry_corner[twin[k] as usize] < c {
            continue;
        }
        let s = edge_s[he_edge[k] as usize];
        if semi_sharp(s) {
            semi_list[vtx(c) as usize].push(s);
            semi_list[vtx(m.next(c)) as usize].push(s);
        }
    }
    let mut span_semi: Vec<Vec<f32>> = vec![Vec::new(); n_spans];
    for &(c, cn, s) in &continuous {
        if semi_sharp(s) {
            span_semi[span_of[c as usize] as usize].push(s);
            span_semi[span_of[cn as usize] as usize].push(s);
        }
    }
    // Chaikin averages an edge's decay over every semi-sharp edge of its cage vertex, and a span sees only
    // its own: the rest (the seam's, the other spans') ride along as hidden edges of the span's UV-cage
    // vertex (`SubdivTags::hidden_semi_sharp`), so the UV cage decays its creases as the cage does.
    let hidden: Vec<Vec<f32>> = if cage.tags.chaikin {
        (0..n_spans)
            .map(|sp| {
                let mut rest = semi_list[span_vertex[sp] as usize].clone();
                for s in &span_semi[sp] {
                    if let Some(i) = rest.iter().position(|x| x == s) {
                        rest.swap_remove(i);
                    }
                }
                if span_semi[sp].is_empty() {
                    // No crease of its own to decay: nothing the hidden edges could change.
                    rest.clear();
                }
                rest
            })
            .collect()
    } else {
        Vec::new()
    };
    // Per span, the sharpness it takes from the other value of its vertex (CornersPlus1/2).
    let mut dependent_sharpness = vec![0.0f32; n_spans];
    let mut inf_edge = vec![false; n_spans];
    for &(c, cn, s) in &continuous {
        if s >= SHARPNESS_INFINITE {
            inf_edge[span_of[c as usize] as usize] = true;
            inf_edge[span_of[cn as usize] as usize] = true;
        }
    }
    let linear_boundaries = matches!(rule, FVarLinear::Boundaries | FVarLinear::All);
    let dependent = matches!(rule, FVarLinear::CornersPlus1 | FVarLinear::CornersPlus2);
    let plus2 = rule == FVarLinear::CornersPlus2;
    let sharpen_darts = plus2 || linear_boundaries;
    let geom_corners_smooth = cage.tags.boundary != BoundaryInterpolation::EdgeAndCorner;
    let fvar_corners_sharp = rule != FVarLinear::None;
    let mut sharp_span = vec![false; n_spans];
    for v in 0..mesh.positions.len() {
        let spans = &vertex_spans[v];
        if spans.is_empty() {
            continue;
        }
        let mut mis = mismatch[v];
        if boundary[v] && !mis {
            mis = linear_boundaries
                || (spans.len() == 1
                    && span_faces[spans[0] as usize] == 1
                    && geom_corners_smooth
                    && fvar_corners_sharp);
        }
        if !mis {
            continue;
        }
        let mut values: Vec<u32> = spans.iter().map(|&s| span_value[s as usize]).collect();
        values.sort_unstable();
        values.dedup();
        let n_values = values.len();
        let disjoint = |s: u32| {
            spans
                .iter()
                .filter(|&&t| span_value[t as usize] == span_value[s as usize])
                .count()
                > 1
        };
        let mut all = linear_boundaries
            || vert_s[v] >= SHARPNESS_INFINITE
            || (dependent && n_values > 2)
            || (sharpen_darts && n_values == 1 && !boundary[v]);
        if !all && dependent && n_values == 2 {
            all = spans.iter().any(|&s| inf_edge[s as usize] || disjoint(s));
            if plus2 {
                all |= spans.iter().any(|&s| span_faces[s as usize] == 1);
            }
        }
        if !all && dependent && spans.len() == 2 && !semi_sharp(vert_s[v]) {
            // Only one span semi-sharp: the other follows it (OpenSubdiv's `hasDependentValuesToSharpen`).
            let (a, b) = (spans[0] as usize, spans[1] as usize);
            let (sa, sb) = (!span_semi[a].is_empty(), !span_semi[b].is_empty());
            if sa != sb {
                let (follower, leader) = if sa { (b, a) } else { (a, b) };
                // The leader's edges among every semi-sharp edge of the vertex, decayed as the cage decays
                // them: the follower is a corner while any is sharp, blended at their last transition.
                let mut mine = span_semi[leader].clone();
                let edges = &semi_list[v];
                let flags: Vec<bool> = edges
                    .iter()
                    .map(|s| match mine.iter().position(|x| x == s) {
                        Some(i) => {
                            mine.swap_remove(i);
                            true
                        }
                        None => false,
                    })
                    .collect();
                dependent_sharpness[follower] =
                    dependent_vertex_sharpness(edges, &flags, cage.tags.chaikin);
            }
        }

        for &s in spans {
            sharp_span[s as usize] = all
                || disjoint(s)
                || inf_edge[s as usize]
                || (span_faces[s as usize] == 1 && fvar_corners_sharp);
        }
    }
    // The UV cage.
    let positions: Vec<DVec3> = span_value
        .iter()
        .map(|&i| {
            let p = uv.values[i as usize];
            DVec3::new(p[0], p[1], 0.0)
        })
        .collect();
    let uv_mesh = Mesh::from_offsets(positions, mesh.face_ptr.clone(), span_of.clone())
        .map_err(|e| Error::Invalid(format!("UV cage: {e}")))?;
    let all_linear = rule == FVarLinear::All;
    let mut tags = SubdivTags {
        boundary: BoundaryInterpolation::EdgeOnly,
        chaikin: cage.tags.chaikin,
        smooth_triangles: cage.tags.smooth_triangles,
        isolation: Some(levels),
        fvar_interpolation: cage.tags.fvar_interpolation,
        holes: (0..mesh.n_faces() as u32)
            .filter(|&f| features.hole[f as usize])
            .collect(),
        ..SubdivTags::default()
    };
    for &(c, cn, s) in &continuous {
        let s = if all_linear { SHARPNESS_INFINITE } else { s };
        if s > 0.0 {
            tags.creases.push(Crease {
                a: span_of[c as usize],
                b: span_of[cn as usize],
                sharpness: s,
            });
        }
    }
    for s in 0..n_spans {
        let inherited = vert_s[span_vertex[s] as usize];
        let sharpness = if all_linear || sharp_span[s] {
            SHARPNESS_INFINITE
        } else {
            inherited.max(dependent_sharpness[s])
        };
        if sharpness > 0.0 {
            tags.corners.push(CornerTag {
                vertex: s as u32,
                sharpness,
            });
        }
    }
    if hidden.iter().any(|h| !h.is_empty()) {
        tags.hidden_semi_sharp = hidden;
    }
    Ok(Some(Cage {
        mesh: uv_mesh,
        tags,
        uv: None,
    }))
}

/// The UV cage of `cage` and its stencils at the positions' level `levels`, checked to match the
/// positions' patch layout (`positions`: their stencils). `None` without UVs.
pub fn uv_stencils(
    cage: &Cage,
    positions: &CageStencils,
    tangents: Tangents,
) -> Result<Option<(Cage, CageStencils)>> {
    let Some(uvc) = uv_cage(cage, positions.levels)? else {
        return Ok(None);
    };
    let cs = GregoryStencils::from_cage(&uvc, tangents)
        .map_err(|e| Error::Invalid(format!("UVs: {e}")))?;
    if cs.levels != positions.levels || cs.stencils.patch_face != positions.stencils.patch_face {
        return Err(Error::Invalid(format!(
            "UVs: the UV patches ({} at level {}) do not match the surface's ({} at level {})",
            cs.stencils.patch_face.len(),
            cs.levels,
            positions.stencils.patch_face.len(),
            positions.levels
        )));
    }
    Ok(Some((uvc, cs)))
}
