//! Mesh reduction by parallel quadric-error edge collapses ("Instant Level-of-Detail" passes over the
//! mesh matrices): every pass collapses, all at once, an independent set of the cheapest valid edges, and
//! applies them as `B' = K·B`, one gather of the index buffer.
//!
//! # Algorithm
//! - Quadrics (Garland–Heckbert): each triangle's plane quadric weighted by the square root of its area
//!   (a length, so a few large triangles do not outweigh the small ones round a silhouette or a small
//!   feature), summed at its corners; each boundary edge adds the quadric of the plane through it
//!   perpendicular to its triangle, weighted by its length × [`BOUNDARY_WEIGHT`], and its triangle's own
//!   plane at the same weight without counting it in the normalisation (so a border vertex resists
//!   leaving the surface as well as leaving the border, in both directions of its edges; meshoptimizer's
//!   weights and mix). A seam edge is not a border of the surface, only of its attributes: it gets
//!   [`SEAM_WEIGHT`] instead, which keeps the seam's line without making it costlier than the surface
//!   round it (with the border's weight the teapot's patch seams held their vertices and the
//!   patches between them paid: 2.6 % Hausdorff at 10 % against meshoptimizer's 0.79 %; now 0.76 %).
//!   A collapse adds the two quadrics. Q(p) / w (w
//!   the summed weights) is a mean squared distance to the planes a vertex stands for; the cost of
//!   placing a collapse at p is the larger of its two endpoints' (each normalised by its own weight: with
//!   the sum's weight, a light vertex — a spike of one triangle — would vanish into a heavy one at a
//!   diluted cost), and `sqrt(cost)` is the error reported, a length.
//! - Placement: [`Placement::Keep`] moves the removed vertex onto the kept one (the cheaper direction
//!   that is valid); [`Placement::Optimal`] places it at the summed quadric's minimum, or at the best
//!   point of the edge when the 3 × 3 system is singular (flat or straight regions) or its solution lies
//!   far from the edge. Boundary edges collapse onto an endpoint in both modes.
//! - One pass: (1) vertex → faces and vertex → neighbours (with each edge's face count) from the current
//!   triangles; (2) every edge's cheapest placement the locks allow (its cost reused from the last pass
//!   when neither endpoint changed); (3) key = (cost as f32, a bijective scramble of the edge index: ties
//!   of a flat region broken in a scattered order, not as a sweep); the pass considers the cheapest
//!   [`PASS_SHARE`] of the edges; (4) rounds of local minima: m1(v) = the least key of v's considered
//!   edges, an edge is a local minimum when its key is the least over the edges touching its endpoints'
//!   closed one-rings; local minima are checked (link condition, valence, flips) and the valid ones block
//!   their closed one-rings for the rest of the pass, up to [`MAX_ROUNDS`] rounds; (5) the chosen
//!   collapses are applied together: positions, quadrics and normals of the survivors, then the index
//!   gather `t' = K[t]`, dropping the triangles that lost a corner. Two chosen edges never touch each
//!   other's closed one-rings, so no triangle moves under two collapses and every check made in (4)
//!   still holds in (5): the pass equals some sequential order of collapses.
//! - The stop: the face target reached (the last pass keeps only its cheapest collapses, in key order),
//!   no valid collapse left, or none under the error bound.
//!
//! # Guarantees (for the edges that are manifold and consistently oriented)
//! - Topology: the link condition Lk(a) ∩ Lk(b) = Lk(ab) on vertices and edges (an interior edge's
//!   endpoints share exactly its two opposite vertices, which do not form a triangle with both; a
//!   boundary edge's exactly one); an interior edge never joins two boundary vertices; an opposite vertex
//!   never drops below valence 3 (interior) or loses its last triangle; a triangle on a non-manifold edge
//!   is never removed. So manifold in gives manifold out, a closed mesh stays closed, the Euler
//!   characteristic and the number of pieces are kept (a tetrahedron is the smallest closed piece, a lone
//!   triangle the smallest open one).
//! - Boundaries: a boundary vertex is only ever kept (its position unchanged) or removed along a boundary
//!   edge onto its neighbour, so a border stays on its own input vertices; `lock_border` pins them all.
//! - Seams: two vertices that share a position bit for bit (an attribute seam as exporters write it)
//!   are twins when their fans are half-discs whose boundary neighbours pair up by position; a seam
//!   vertex goes only along the seam and only with its twin (the twin edge's collapse made in the same
//!   pass, onto the same point, both checked), so a seam reduces and stays closed. Vertices sharing their
//!   position with two or more others (seam ends, corners where several seams meet), pairs that do not
//!   match, and every vertex of a non-manifold or inconsistently oriented fan are locked: never removed
//!   nor moved (weld first to reduce them).
//! - No flips: a collapse is rejected when a triangle it moves turns by more than acos([`MAX_TURN_COS`]),
//!   becomes degenerate, or faces against the input's area-weighted normal summed over the input
//!   vertices its corners stand for (so turns that are small one collapse at a time cannot add up to a
//!   fold).
//! - Deterministic: every per-vertex or per-edge result is computed in a fixed order within fixed blocks
//!   and keys are unique, so the result does not depend on the number of threads.
//! - `allow_topology` drops the link, valence and boundary-joining rules (holes may close, handles may
//!   pinch, pieces may vanish); triangles that lose a corner are removed, and so are the duplicates a
//!   collapse makes.
//!
//! # Cost model
//! A pass is O(F + V) for the adjacency and the gather, O(E) for the costs (only the edges around the last
//! pass's survivors are costed again, across the vertex arrays' compactions too) and the rounds, and O(E'·d)
//! for the checks of the local minima (d the valence). Each valid collapse blocks about 10 vertices, so a
//! pass collapses up to about 8 % of the vertices: a reduction to 50 % takes ~7 passes and to 1 % ~40 over a
//! shrinking mesh (measured on the bunny). A seam candidate finds its twin edge again (a scan of one
//! vertex's neighbours) each time a stage touches it rather than widening every candidate, so a seam edge
//! costs a few times an ordinary one in the rounds (the teapot, 662 seam vertices of 3,644, is in the tests
//! and the bench). The worst cases: a mesh where most edges are invalid (locked vertices, unwelded soups:
//! every vertex on a border of its own lone triangle — nothing is a candidate, one pass and out), rounds of invalid local minima (a chain where each round finds the next: capped at
//! [`MAX_ROUNDS`] a pass, when every considered edge is invalid the pass considers four times as many), flat
//! regions where every cost ties (the scrambled tie-break keeps them parallel: a tessellated box goes from
//! 8,064 to 806 triangles in 28 passes, against 199 with ties broken by index) and a high-valence fan (a
//! 4,000-gon's fan vertex: its checks cost d² and only one of its edges collapses a pass; measured in
//! `tests/mesh_simplify.rs`). Passes are capped at [`MAX_PASSES`]. A deep reduction ends in many small passes
//! (a 1 % target: 30–60 of them), so loops over fewer than [`PARALLEL_MIN`] items run on the calling thread:
//! waking the pool for each round of each pass cost more than the work (`examples/simplify_profile.rs` over
//! the bench's meshes: system time, mostly the pool's yields, 3.3–3.7 s → 0.6–0.9 s of 13–16 s of CPU; the
//! same triangles). `GREGVOX_SIMPLIFY_TIMES=1` prints the stages' times and each pass's counts. Every
//! stage is bound by memory latency, so the order of work matters: the rounds check their local minima in
//! memory order, and a check made in key order instead (a random part of the mesh each time) costs about
//! ten times as much (0.3 µs against ~3 µs on the CAD block of the bench; `docs/dev-mesh.md` has this and
//! the other measured alternatives).
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Weight of a boundary edge's perpendicular plane (and of its triangle's plane), per unit of edge length.
pub const BOUNDARY_WEIGHT: f64 = 10.0;
/// [`BOUNDARY_WEIGHT`] for a seam edge (each side's; see the module docs).
pub const SEAM_WEIGHT: f64 = 0.5;
/// A moved triangle must keep its normal within acos(0.2) ≈ 78° of where it was.
pub const MAX_TURN_COS: f64 = 0.2;
/// Passes stop after this many (the reduction reached so far is returned).
pub const MAX_PASSES: usize = 100_000;
/// A pass considers this share of the candidate edges, the cheapest.
pub const PASS_SHARE: f64 = 0.2;
/// A pass considers the candidates up to this factor of its share's largest cost.
pub const SLACK: f32 = 1.5;
/// Rounds of local-minimum selection per pass (a bound on a pass's work: see the cost model).
pub const MAX_ROUNDS: usize = 16;
/// Vertices per block of the parallel loops (fixed, so results do not depend on the thread count).
const BLOCK: usize = 2048;
/// The stages `GREGVOX_SIMPLIFY_TIMES` reports, in order.
const STAGES: [&str; 12] = [
    "input",
    "adjacency",
    "locks",
    "quadrics",
    "normals",
    "setup",
    "pass adjacency (and the last pass's compaction)",
    "pass candidates",
    "pass selection",
    "pass independent sets",
    "pass collapses",
    "the last pass's tail",
];
/// Loops over fewer items than this run on the calling thread (the late passes of a deep reduction are
/// many and small: waking the pool cost more than their work).
pub const PARALLEL_MIN: usize = 4096;

/// Where the merged vertex of a collapse goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Placement {
    /// On one of the two endpoints (the output's vertices are a subset of the input's).
    Keep,
    /// At the quadric's minimum (on the edge where the quadric is singular).
    #[default]
    Optimal,
}

/// What to reduce to and what to keep.
#[derive(Debug, Clone, PartialEq)]
pub struct SimplifyOptions {
    /// Stop when at most this many triangles are left.
    pub target_faces: usize,
    /// Never make a collapse whose error (a length, see the module docs) exceeds this.
    pub max_error: f64,
    /// See [`Placement`].
    pub placement: Placement,
    /// Boundary vertices never move nor disappear.
    pub lock_border: bool,
    /// Drop the rules that keep the topology (see the module docs).
    pub allow_topology: bool,
    /// Before reducing, remove the pieces (vertex-connected) whose bounding-box diagonal is at most this
    /// fraction of the whole mesh's; 0 keeps every piece.
    pub prune: f64,
}

impl Default for SimplifyOptions {
    fn default() -> Self {
        SimplifyOptions {
            target_faces: 0,
            max_error: f64::INFINITY,
            placement: Placement::Optimal,
            lock_border: false,
            allow_topology: false,
            prune: 0.0,
        }
    }
}

/// A reduced triangle mesh and how it was reached.
#[derive(Debug, Clone, PartialEq)]
pub struct Simplified {
    /// The referenced vertices, in the order of their first input ids.
    pub positions: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    /// For every output vertex, the input vertex it stands for (the survivor of its collapses).
    pub source_vertex: Vec<u32>,
    /// The largest collapse error made (a length: see the module docs); 0 when nothing collapsed.
    pub error: f64,
    /// Collapses made.
    pub collapses: usize,
    /// Parallel passes run.
    pub passes: usize,
    /// Vertices locked (seams, non-manifold fans, and with `lock_border` the boundary).
    pub locked_vertices: usize,
    /// Triangles removed with pruned pieces.
    pub pruned_triangles: usize,
    /// Triangles dropped on input because two corners were the same vertex.
    pub degenerate_input: usize,
}

/// A symmetric quadric Q(p) = pᵀAp + 2bᵀp + c with its weight.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Quadric {
    /// a00 a01 a02 a11 a12 a22
    a: [f64; 6],
    b: [f64; 3],
    c: f64,
    w: f64,
}

impl Quadric {
    /// The plane n·p + d = 0 (n unit), weighted.
    fn plane(n: DVec3, d: f64, w: f64) -> Quadric {
        Quadric {
            a: [
                w * n.x * n.x,
                w * n.x * n.y,
                w * n.x * n.z,
                w * n.y * n.y,
                w * n.y * n.z,
                w * n.z * n.z,
            ],
            b: [w * n.x * d, w * n.y * d, w * n.z * d],
            c: w * d * d,
            w,
        }
    }
    fn add(&mut self, o: &Quadric) {
        for k in 0..6 {
            self.a[k] += o.a[k];
        }
        for k in 0..3 {
            self.b[k] += o.b[k];
        }
        self.c += o.c;
        self.w += o.w;
    }
    fn sum(&self, o: &Quadric) -> Quadric {
        let mut s = *self;
        s.add(o);
        s
    }
    fn a_times(&self, p: DVec3) -> DVec3 {
        let a = &self.a;
        DVec3::new(
            a[0] * p.x + a[1] * p.y + a[2] * p.z,
            a[1] * p.x + a[3] * p.y + a[4] * p.z,
            a[2] * p.x + a[4] * p.y + a[5] * p.z,
        )
    }
    fn b(&self) -> DVec3 {
        DVec3::from_array(self.b)
    }
    /// Q(p) / w, clamped at 0 (rounding can make it slightly negative).
    fn cost(&self, p: DVec3) -> f64 {
        if self.w <= 0.0 {
            return 0.0;
        }
        let q = p.dot(self.a_times(p)) + 2.0 * self.b().dot(p) + self.c;
        (q / self.w).max(0.0)
    }
    /// The minimiser of Q when A is well conditioned.
    fn minimiser(&self) -> Option<DVec3> {
        let a = &self.a;
        let m = glam::DMat3::from_cols(
            DVec3::new(a[0], a[1], a[2]),
            DVec3::new(a[1], a[3], a[4]),
            DVec3::new(a[2], a[4], a[5]),
        );
        let det = m.determinant();
        let tr = a[0] + a[3] + a[5];
        // Relative to the scale of A: a rank-deficient A (flat or straight region) has det ≈ 0.
        if tr.is_nan() || tr <= 0.0 || det.abs() <= 1e-9 * (tr / 3.0).powi(3) {
            return None;
        }
        let x = m.inverse() * (-self.b());
        x.is_finite().then_some(x)
    }
}

/// Vertex flags.
const LOCKED: u8 = 1;
/// Vertex flag: the vertex has a twin across a seam (see `seam_twins`).
const SEAM: u8 = 2;
/// No twin: the vertex is not on a seam.
const NO_TWIN: u32 = u32::MAX;

/// The per-pass adjacency: vertex → faces, vertex → distinct neighbours with the edge's face count.
struct Adjacency {
    vf_ptr: Vec<u32>,
    vf: Vec<u32>,
    /// Neighbours of v: `nb[2·vf_ptr[v] .. 2·vf_ptr[v] + nb_len[v]]`, sorted.
    nb: Vec<u32>,
    /// Faces on edge (v, neighbour), parallel to `nb`.
    nb_faces: Vec<u8>,
    nb_len: Vec<u32>,
    /// Whether v has a boundary edge (an edge with one triangle).
    border: Vec<bool>,
}

impl Adjacency {
    fn build(n: usize, tri: &[[u32; 3]]) -> Adjacency {
        let mut vf_ptr = vec![0u32; n + 1];
        for t in tri {
            for &v in t {
                vf_ptr[v as usize + 1] += 1;
            }
        }
        for v in 0..n {
            vf_ptr[v + 1] += vf_ptr[v];
        }
        let mut fill = vf_ptr.clone();
        let mut vf = vec![0u32; vf_ptr[n] as usize];
        for (f, t) in tri.iter().enumerate() {
            for &v in t {
                vf[fill[v as usize] as usize] = f as u32;
                fill[v as usize] += 1;
            }
        }
        let total = 2 * vf.len();
        let mut nb = vec![0u32; total];
        let mut nb_faces = vec![0u8; total];
        let mut nb_len = vec![0u32; n];
        let mut border = vec![false; n];
        {
            let starts: Vec<usize> = (0..n.div_ceil(BLOCK))
                .map(|b| 2 * vf_ptr[b * BLOCK] as usize)
                .collect();
            let nb_blocks = split_at_offsets(&mut nb, &starts);
            let nbf_blocks = split_at_offsets(&mut nb_faces, &starts);
            // One block: a vertex's distinct neighbours (sorted), each edge's face count, and whether the
            // vertex has a boundary edge.
            let block = |(b, ((nbs, nbfs), (lens, borders))): (usize, BlockSlices)| {
                let base = 2 * vf_ptr[b * BLOCK] as usize;
                let mut scratch: Vec<u32> = Vec::new();
                for (i, (len, on_border)) in lens.iter_mut().zip(borders.iter_mut()).enumerate() {
                    let v = (b * BLOCK + i) as u32;
                    let (s, e) = (vf_ptr[v as usize] as usize, vf_ptr[v as usize + 1] as usize);
                    scratch.clear();
                    for &f in &vf[s..e] {
                        for &u in &tri[f as usize] {
                            if u != v {
                                scratch.push(u);
                            }
                        }
                    }
                    scratch.sort_unstable();
                    let out = 2 * s - base;
                    let mut k = 0usize;
                    let mut j = 0usize;
                    while j < scratch.len() {
                        let u = scratch[j];
                        let mut c = 0usize;
                        while j < scratch.len() && scratch[j] == u {
                            c += 1;
                            j += 1;
                        }
                        nbs[out + k] = u;
                        nbfs[out + k] = c.min(255) as u8;
                        *on_border |= c == 1;
                        k += 1;
                    }
                    *len = k as u32;
                }
            };
            let blocks: Vec<_> = nb_blocks
                .into_iter()
                .zip(nbf_blocks)
                .zip(nb_len.chunks_mut(BLOCK).zip(border.chunks_mut(BLOCK)))
                .enumerate()
                .collect();
            if n >= PARALLEL_MIN {
                blocks.into_par_iter().for_each(block);
            } else {
                blocks.into_iter().for_each(block);
            }
        }
        Adjacency {
            vf_ptr,
            vf,
            nb,
            nb_faces,
            nb_len,
            border,
        }
    }
    fn faces(&self, v: u32) -> &[u32] {
        &self.vf[self.vf_ptr[v as usize] as usize..self.vf_ptr[v as usize + 1] as usize]
    }
    fn neighbours(&self, v: u32) -> (&[u32], &[u8]) {
        let s = 2 * self.vf_ptr[v as usize] as usize;
        let e = s + self.nb_len[v as usize] as usize;
        (&self.nb[s..e], &self.nb_faces[s..e])
    }
    fn is_border(&self, v: u32) -> bool {
        self.border[v as usize]
    }
}

/// One block of [`Adjacency::build`]'s outputs: neighbours, their face counts, lengths and border flags.
type BlockSlices<'a> = (
    (&'a mut [u32], &'a mut [u8]),
    (&'a mut [u32], &'a mut [bool]),
);

/// Splits `data` at the given increasing offsets (the first is the start of the first piece).
fn split_at_offsets<'a, T>(data: &'a mut [T], starts: &[usize]) -> Vec<&'a mut [T]> {
    let mut out = Vec::with_capacity(starts.len());
    let mut rest = data;
    let mut at = starts.first().copied().unwrap_or(0);
    rest = &mut rest[at..];
    for k in 0..starts.len() {
        let end = starts.get(k + 1).copied().unwrap_or(at + rest.len());
        let (head, tail) = rest.split_at_mut(end - at);
        out.push(head);
        rest = tail;
        at = end;
    }
    out
}

/// An edge that may collapse, with the cost of its cheapest placement (validity not yet checked).
#[derive(Debug, Clone, Copy)]
struct Candidate {
    a: u32,
    b: u32,
    faces: u8,
    cost: f64,
    /// On a seam: collapsed together with its twin edge (`State::twin_edge`, found again when needed:
    /// seam edges are few, and a wider candidate slows every pass).
    seam: bool,
}

/// The last pass's candidates, for the edges whose endpoints it left alone.
struct Cache {
    /// Sorted by (a, b), a < b.
    cands: Vec<Candidate>,
    /// `cands[ptr[a] .. ptr[a + 1]]` are the edges a owns.
    ptr: Vec<u32>,
    /// The survivors and the removed vertices of the last pass.
    dirty: Vec<bool>,
    /// The last pass's boundary flags.
    border: Vec<bool>,
}

/// A valid collapse: `remove` goes into `keep`, which moves to `to`.
#[derive(Debug, Clone, Copy)]
struct Collapse {
    keep: u32,
    remove: u32,
    to: DVec3,
    cost: f64,
    /// On a seam, the twin collapse made with it: (remove, keep) on the other side, moving nothing.
    twin: Option<[u32; 2]>,
}

/// The simplifier's state between passes.
struct State<'a> {
    pos: Vec<DVec3>,
    quad: Vec<Quadric>,
    /// The input's area-weighted normal summed over the input vertices each vertex stands for: the
    /// orientation of the original surface that a moved triangle must keep facing.
    normal: Vec<DVec3>,
    flags: Vec<u8>,
    /// A seam vertex's twin: the vertex at the same position on the seam's other side (`NO_TWIN` else).
    twin: Vec<u32>,
    tri: Vec<[u32; 3]>,
    opts: &'a SimplifyOptions,
}

/// Whether the fan of triangles around `v` is one disc or half-disc, consistently oriented.
fn fan_is_manifold(v: u32, faces: &[u32], tri: &[[u32; 3]]) -> bool {
    // Most fans are small: sorted on the stack, no allocation per vertex.
    const SMALL: usize = 32;
    if faces.len() <= SMALL {
        let mut pn = [(0u32, 0u32); SMALL];
        let mut nexts = [0u32; SMALL];
        fan_chain(
            v,
            faces,
            tri,
            &mut pn[..faces.len()],
            &mut nexts[..faces.len()],
        )
    } else {
        let mut pn = vec![(0u32, 0u32); faces.len()];
        let mut nexts = vec![0u32; faces.len()];
        fan_chain(v, faces, tri, &mut pn, &mut nexts)
    }
}

/// [`fan_is_manifold`] with its scratch (`pn` and `nexts` as long as `faces`).
fn fan_chain(
    v: u32,
    faces: &[u32],
    tri: &[[u32; 3]],
    pn: &mut [(u32, u32)],
    nexts: &mut [u32],
) -> bool {
    // (previous, next) corner of v in every face; the fan is one chain when following next → previous
    // visits every face once. Sorted lookups: O(d log d) for a vertex of d faces (a huge polygon's fan
    // vertex has all of them).
    for (slot, &f) in pn.iter_mut().zip(faces) {
        let t = tri[f as usize];
        let k = t.iter().position(|&x| x == v).unwrap_or(0);
        *slot = (t[(k + 2) % 3], t[(k + 1) % 3]);
    }
    let n = pn.len();
    if n <= 1 {
        return true;
    }
    pn.sort_unstable();
    for (x, p) in nexts.iter_mut().zip(pn.iter()) {
        *x = p.1;
    }
    nexts.sort_unstable();
    // Each corner may appear at most once as a "next" and once as a "prev".
    if nexts.windows(2).any(|w| w[0] == w[1]) || pn.windows(2).any(|w| w[0].0 == w[1].0) {
        return false;
    }
    // Start from a face whose prev is nobody's next (the fan's open end), else anywhere.
    let start = (0..n)
        .find(|&i| nexts.binary_search(&pn[i].0).is_err())
        .unwrap_or(0);
    let mut seen = 1usize;
    let mut cur = start;
    loop {
        let next = pn[cur].1;
        match pn.binary_search_by_key(&next, |p| p.0) {
            Ok(i) if i != start => {
                cur = i;
                seen += 1;
                if seen > n {
                    return false;
                }
            }
            _ => break,
        }
    }
    seen == n
}

impl State<'_> {
    /// Candidate collapses of every edge owned (lower id) by the vertices of block `b`: the cheapest
    /// placement the locks and the boundary rule allow, under `bound`, not yet checked for validity. An
    /// edge whose endpoints the last pass left alone (same quadric, position and boundary status) takes
    /// the last pass's answer from `cache`: only the edges around the survivors are costed again.
    fn candidates(
        &self,
        adj: &Adjacency,
        b: usize,
        bound: f64,
        cache: Option<&Cache>,
    ) -> Vec<Candidate> {
        let n = self.pos.len();
        let mut out = Vec::new();
        let clean = |v: u32| {
            cache.is_some_and(|c| !c.dirty[v as usize] && c.border[v as usize] == adj.is_border(v))
        };
        for v in b * BLOCK..((b + 1) * BLOCK).min(n) {
            let a = v as u32;
            let (nbs, nbf) = adj.neighbours(a);
            let a_clean = clean(a);
            for (k, &u) in nbs.iter().enumerate() {
                if u < a {
                    continue;
                }
                let on_seam = (self.flags[v] | self.flags[u as usize]) & SEAM != 0;
                let twin = if nbf[k] == 1 && on_seam {
                    self.twin_edge(adj, a, u)
                } else {
                    [NO_TWIN; 2]
                };
                let seam = twin[0] != NO_TWIN;
                // A seam pair is one candidate, kept on the side whose edge has the smaller vertex id.
                if seam && a > twin[0].min(twin[1]) {
                    continue;
                }
                // (A seam edge's cost depends on its twins too, which the cache does not follow.)
                if let (true, false, Some(c)) = (a_clean && clean(u), seam, cache) {
                    let owned = &c.cands[c.ptr[v] as usize..c.ptr[v + 1] as usize];
                    if let Ok(i) = owned.binary_search_by_key(&u, |x| x.b) {
                        out.push(owned[i]);
                    }
                    continue;
                }
                let opts = self.options(adj, a, u, nbf[k], twin);
                let best = opts
                    .iter()
                    .flatten()
                    .map(|c| c.cost)
                    .fold(f64::INFINITY, f64::min);
                if best <= bound {
                    out.push(Candidate {
                        a,
                        b: u,
                        faces: nbf[k],
                        cost: best,
                        seam,
                    });
                }
            }
        }
        out
    }

    /// The twin of boundary edge (a, b) when an endpoint is a seam vertex: the boundary edge on the seam's
    /// other side at the same two positions (`NO_TWIN` twice when neither endpoint is on a seam, and
    /// `NO_TWIN` in place of an endpoint that has no counterpart there).
    fn twin_edge(&self, adj: &Adjacency, a: u32, b: u32) -> [u32; 2] {
        let (ta, tb) = (self.twin[a as usize], self.twin[b as usize]);
        // The boundary neighbour of `s` at `other`'s position.
        let at = |s: u32, other: u32| {
            let (nbs, nbf) = adj.neighbours(s);
            let p = self.pos[other as usize];
            nbs.iter()
                .zip(nbf)
                .find(|(&u, &f)| f == 1 && self.pos[u as usize] == p)
                .map_or(NO_TWIN, |(&u, _)| u)
        };
        if ta != NO_TWIN {
            [ta, at(ta, b)]
        } else if tb != NO_TWIN {
            [at(tb, a), tb]
        } else {
            [NO_TWIN; 2]
        }
    }

    /// The placements edge (a, b) with `faces` triangles on it may take (at most two), with their costs;
    /// on a seam, `twin` is its twin edge (see [`State::twin_edge`]), and both collapse together.
    fn options(
        &self,
        adj: &Adjacency,
        a: u32,
        b: u32,
        faces: u8,
        twin: [u32; 2],
    ) -> [Option<Collapse>; 2] {
        let none = [None, None];
        let (fa, fb) = (self.flags[a as usize], self.flags[b as usize]);
        if (fa & LOCKED != 0 && fb & LOCKED != 0) || faces == 0 || faces > 2 {
            return none;
        }
        let border_edge = faces == 1;
        let (ba, bb) = (adj.is_border(a), adj.is_border(b));
        if !self.opts.allow_topology && !border_edge && ba && bb {
            return none; // would pinch two boundary stretches together
        }
        let (qa, qb) = (&self.quad[a as usize], &self.quad[b as usize]);
        // The error of a placement is the larger of the two endpoints' own (each one's planes, each
        // normalised by its own weight): the sum's normalisation would let a light vertex (a spike of one
        // triangle) vanish into a heavy one at a diluted cost.
        // On a seam the other side's planes count too (its twin vertices stand at the same points).
        let [ta, tb] = twin;
        let seam = ta != NO_TWIN && tb != NO_TWIN;
        let cost = |p: DVec3| {
            let c = qa.cost(p).max(qb.cost(p));
            if seam {
                c.max(self.quad[ta as usize].cost(p))
                    .max(self.quad[tb as usize].cost(p))
            } else {
                c
            }
        };
        let (pa, pb) = (self.pos[a as usize], self.pos[b as usize]);
        // A locked vertex never goes; on an interior edge a boundary vertex stays where it is; a seam
        // vertex goes only along its seam, with its twin, and on a seam only seam vertices go.
        let (sa, sb) = (fa & SEAM != 0, fb & SEAM != 0);
        if border_edge && !seam && (sa || sb) {
            return none; // a seam edge without its twin: it would tear the seam
        }
        let can_remove_a = fa & LOCKED == 0 && (border_edge || !ba) && sa == seam;
        let can_remove_b = fb & LOCKED == 0 && (border_edge || !bb) && sb == seam;
        // Boundary edges collapse onto an endpoint: the border stays on its own vertices.
        if self.opts.placement == Placement::Optimal && can_remove_a && can_remove_b && !border_edge
        {
            let to = optimal_point(&qa.sum(qb), pa, pb);
            return [
                Some(Collapse {
                    keep: a,
                    remove: b,
                    to,
                    cost: cost(to),
                    twin: None,
                }),
                None,
            ];
        }
        let mut out = none;
        if can_remove_b {
            out[0] = Some(Collapse {
                keep: a,
                remove: b,
                to: pa,
                cost: cost(pa),
                twin: seam.then_some([tb, ta]),
            });
        }
        if can_remove_a {
            out[1] = Some(Collapse {
                keep: b,
                remove: a,
                to: pb,
                cost: cost(pb),
                twin: seam.then_some([ta, tb]),
            });
        }
        out
    }

    /// The cheapest placement of a candidate that keeps the topology and flips nothing, if any.
    fn validate(&self, adj: &Adjacency, c: &Candidate, bound: f64) -> Option<Collapse> {
        let border_edge = c.faces == 1;
        if !self.opts.allow_topology && !self.link_ok(adj, c.a, c.b, border_edge) {
            return None;
        }
        let twin = if c.seam {
            self.twin_edge(adj, c.a, c.b)
        } else {
            [NO_TWIN; 2]
        };
        if c.seam {
            // The two halves of a seam collapse must be checkable one at a time (see
            // `halves_independent`), and the twin must keep the topology too.
            let [ta, tb] = twin;
            if ta == NO_TWIN || tb == NO_TWIN || !self.halves_independent(adj, [c.a, c.b], [ta, tb])
            {
                return None;
            }
            if !self.opts.allow_topology && !self.link_ok(adj, ta, tb, true) {
                return None;
            }
        }
        let mut opts = self.options(adj, c.a, c.b, c.faces, twin);
        // Cheaper direction first (None last).
        opts.sort_by(|x, y| match (x, y) {
            (Some(x), Some(y)) => x.cost.total_cmp(&y.cost),
            (x, y) => y.is_some().cmp(&x.is_some()),
        });
        // `bound` is the pass's cost limit: the other direction of an edge is taken only if it is as
        // cheap as the edges this pass considers (a corner must not go because its edge was cheap the
        // other way round).
        opts.into_iter()
            .flatten()
            .filter(|o| o.cost as f32 <= bound as f32)
            .find(|o| {
                let moved_keep = self.pos[o.keep as usize] != o.to;
                self.no_flips(adj, o.remove, o.keep, o.to)
                    && (!moved_keep || self.no_flips(adj, o.keep, o.remove, o.to))
                    && o.twin.is_none_or(|[r, k]| self.no_flips(adj, r, k, o.to))
            })
    }

    /// The vertices a candidate's collapse moves or removes: the edge's ends, and on a seam its twin's.
    #[inline]
    fn touched(&self, adj: &Adjacency, c: &Candidate) -> ([u32; 4], usize) {
        if !c.seam {
            return ([c.a, c.b, NO_TWIN, NO_TWIN], 2);
        }
        let [ta, tb] = self.twin_edge(adj, c.a, c.b);
        let n = if ta != NO_TWIN && tb != NO_TWIN { 4 } else { 2 };
        ([c.a, c.b, ta, tb], n)
    }

    /// Whether the two halves of a seam collapse, the boundary edges `x` and `y`, can be checked and made
    /// one after the other with the checks each passed alone: no vertex of one half is a neighbour of the
    /// other (so no triangle is moved by both, and neither half's link changes under the other), and
    /// neither half's opposite vertex (the third corner of its one triangle, which loses an edge) is a
    /// neighbour of the other half (so no vertex loses an edge to both). A shared neighbour elsewhere only
    /// sees two of its edges renamed. Closed one-rings kept wholly apart, the earlier rule, refused 90 %
    /// of the teapot's late seam candidates: where a patch has shrunk to a strip, its two seams share
    /// neighbours.
    fn halves_independent(&self, adj: &Adjacency, x: [u32; 2], y: [u32; 2]) -> bool {
        let opposite = |e: [u32; 2]| {
            adj.faces(e[0])
                .iter()
                .map(|&f| self.tri[f as usize])
                .find(|t| t.contains(&e[1]))
                .and_then(|t| t.into_iter().find(|&v| v != e[0] && v != e[1]))
        };
        let (Some(ox), Some(oy)) = (opposite(x), opposite(y)) else {
            return false;
        };
        let touches = |e: [u32; 2], others: [u32; 3]| {
            e.iter()
                .any(|&v| adj.neighbours(v).0.iter().any(|u| others.contains(u)))
        };
        !touches(x, [y[0], y[1], oy]) && !touches(y, [x[0], x[1], ox])
    }

    /// The link condition Lk(a) ∩ Lk(b) = Lk(ab) (vertices and edges, with a dummy vertex joined to the
    /// boundary) and the valence rules of the opposite vertices.
    fn link_ok(&self, adj: &Adjacency, a: u32, b: u32, border_edge: bool) -> bool {
        // The vertices opposite the edge: one per triangle on it.
        let mut opp = [u32::MAX; 2];
        let mut n_opp = 0;
        for &f in adj.faces(a) {
            let t = self.tri[f as usize];
            if t.contains(&b) {
                if n_opp == 2 {
                    return false;
                }
                opp[n_opp] = t.into_iter().find(|&x| x != a && x != b).unwrap_or(a);
                n_opp += 1;
            }
        }
        if n_opp != if border_edge { 1 } else { 2 } {
            return false;
        }
        // Vertices of the links: the common neighbours are exactly the opposite vertices.
        let (na, fa) = adj.neighbours(a);
        let (nb, fb) = adj.neighbours(b);
        let (mut i, mut j, mut common) = (0, 0, 0);
        while i < na.len() && j < nb.len() {
            match na[i].cmp(&nb[j]) {
                std::cmp::Ordering::Less => i += 1,
                std::cmp::Ordering::Greater => j += 1,
                std::cmp::Ordering::Equal => {
                    let c = na[i];
                    if !opp[..n_opp].contains(&c) {
                        return false;
                    }
                    common += 1;
                    let c_faces = adj.faces(c).len();
                    // c loses a triangle: it must keep one, and an interior c must keep valence ≥ 3.
                    if c_faces <= 1 || (!adj.is_border(c) && c_faces <= 3) {
                        return false;
                    }
                    // A triangle a b c whose other two edges are boundary edges too would fold to an edge
                    // (the dummy edge c–∞ in both links); a triangle on a non-manifold edge stays.
                    if (border_edge && fa[i] == 1 && fb[j] == 1) || fa[i] > 2 || fb[j] > 2 {
                        return false;
                    }
                    i += 1;
                    j += 1;
                }
            }
        }
        if common != n_opp {
            return false;
        }
        // Edges of the links: an interior edge's opposite vertices c, d must not form a triangle with both
        // a and b (a valence-3 vertex over an existing triangle: the collapse would double it).
        if !border_edge {
            let (c, d) = (opp[0], opp[1]);
            let has_cd = |v: u32| {
                adj.faces(v).iter().any(|&f| {
                    let t = self.tri[f as usize];
                    t.contains(&c) && t.contains(&d)
                })
            };
            if has_cd(a) && has_cd(b) {
                return false;
            }
        }
        true
    }

    /// Whether moving `v` to `to` (merging it with `other`) keeps every surviving triangle of `v` turned
    /// by less than acos([`MAX_TURN_COS`]) and non-degenerate.
    fn no_flips(&self, adj: &Adjacency, v: u32, other: u32, to: DVec3) -> bool {
        let merged = self.normal[v as usize] + self.normal[other as usize];
        for &f in adj.faces(v) {
            let t = self.tri[f as usize];
            if t.contains(&other) {
                continue; // removed by the collapse
            }
            let p = t.map(|x| self.pos[x as usize]);
            let n0 = (p[1] - p[0]).cross(p[2] - p[0]);
            let q = t.map(|x| if x == v { to } else { self.pos[x as usize] });
            let n1 = (q[1] - q[0]).cross(q[2] - q[0]);
            let l0 = n0.length_squared();
            if l0 == 0.0 {
                continue; // a degenerate triangle has no orientation to keep
            }
            let l1 = n1.length_squared();
            if l1 <= l0 * 1e-12 || n0.dot(n1) <= MAX_TURN_COS * (l0 * l1).sqrt() {
                return false;
            }
            // Against the input, not only the previous step: turns of less than 90° per collapse must
            // not add up to a fold.
            let reference: DVec3 = t
                .iter()
                .map(|&x| {
                    if x == v {
                        merged
                    } else {
                        self.normal[x as usize]
                    }
                })
                .sum();
            if n1.dot(reference) <= 0.0 {
                return false;
            }
        }
        true
    }
}

/// The quadric's minimiser when it is well defined and near the edge, else the best point of the edge.
fn optimal_point(q: &Quadric, pa: DVec3, pb: DVec3) -> DVec3 {
    let d = pb - pa;
    let len = d.length();
    if let Some(x) = q.minimiser() {
        // Far from the edge the quadric is extrapolating: keep to the edge's neighbourhood.
        if x.distance(0.5 * (pa + pb)) <= len {
            return x;
        }
    }
    // Q(pa + t d) = Q(pa) + 2t (A pa + b)·d + t² dᵀAd.
    let g = (q.a_times(pa) + q.b()).dot(d);
    let h = d.dot(q.a_times(d));
    let t = if h > 0.0 {
        (-g / h).clamp(0.0, 1.0)
    } else {
        0.5
    };
    let mut best = pa + t * d;
    let mut best_cost = q.cost(best);
    for p in [pa, pb, 0.5 * (pa + pb)] {
        let c = q.cost(p);
        if c < best_cost {
            best = p;
            best_cost = c;
        }
    }
    best
}

/// Reduces a triangle mesh (see the module docs). Indices must be in range (the API validates them).
pub fn simplify(positions: &[DVec3], triangles: &[[u32; 3]], opts: &SimplifyOptions) -> Simplified {
    let n = positions.len();
    let mut tri: Vec<[u32; 3]> = triangles
        .iter()
        .copied()
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
        .collect();
    let degenerate_input = triangles.len() - tri.len();
    // `GREGVOX_SIMPLIFY_TIMES=1`: the stages' times (summed over the passes) and each pass's counts on
    // stderr, as `GREGVOX_GWN_TIMES` does for the winding number.
    let timing = std::env::var_os("GREGVOX_SIMPLIFY_TIMES").is_some();
    let mut tm = [0f64; STAGES.len()];
    let mut clock = std::time::Instant::now();
    let mut lap = |k: usize, tm: &mut [f64; STAGES.len()]| {
        let now = std::time::Instant::now();
        tm[k] += (now - clock).as_secs_f64() * 1e3;
        clock = now;
    };
    let mut pruned_triangles = 0;
    if opts.prune > 0.0 {
        let before = tri.len();
        tri = prune_small_pieces(positions, tri, opts.prune);
        pruned_triangles = before - tri.len();
    }
    lap(0, &mut tm);
    let adj = Adjacency::build(n, &tri);
    lap(1, &mut tm);
    // Locks: non-manifold fans, vertices sharing their position with more than one other, seam vertices
    // whose seam does not pair up (see `seam_twins`), and optionally the border.
    let mut flags = vec![0u8; n];
    let referenced: Vec<bool> = (0..n).map(|v| adj.vf_ptr[v] < adj.vf_ptr[v + 1]).collect();
    flags.par_iter_mut().enumerate().for_each(|(v, fl)| {
        let v = v as u32;
        let (_, nbf) = adj.neighbours(v);
        if nbf.iter().any(|&c| c > 2) || !fan_is_manifold(v, adj.faces(v), &tri) {
            *fl |= LOCKED;
        }
    });
    let twin = seam_twins(positions, &adj, &referenced, &mut flags);
    if opts.lock_border {
        for v in 0..n {
            if adj.is_border(v as u32) && twin[v] == NO_TWIN {
                flags[v] |= LOCKED;
            }
        }
    }
    let locked_vertices = (0..n)
        .filter(|&v| referenced[v] && flags[v] & LOCKED != 0)
        .count();
    lap(2, &mut tm);
    let quad = initial_quadrics(positions, &tri, &adj, &twin);
    lap(3, &mut tm);
    let normal: Vec<DVec3> = (0..n as u32)
        .into_par_iter()
        .map(|v| {
            adj.faces(v)
                .iter()
                .map(|&f| {
                    let p = tri[f as usize].map(|x| positions[x as usize]);
                    (p[1] - p[0]).cross(p[2] - p[0])
                })
                .sum()
        })
        .collect();
    lap(4, &mut tm);
    let mut st = State {
        pos: positions.to_vec(),
        quad,
        normal,
        flags,
        twin,
        tri,
        opts,
    };
    // The original id of each current vertex (vertices are renumbered when compacted).
    let mut ids: Vec<u32> = (0..n as u32).collect();
    let bound = if opts.max_error.is_finite() {
        opts.max_error.max(0.0).powi(2)
    } else {
        f64::INFINITY
    };
    let (mut error2, mut collapses, mut passes) = (0.0f64, 0usize, 0usize);
    let mut adj = Some(adj);
    let mut cache: Option<Cache> = None;
    lap(5, &mut tm);
    // Vertices removed since the arrays were last compacted (the unreferenced input ones count too).
    let mut dead = referenced.iter().filter(|&&r| !r).count();
    while st.tri.len() > opts.target_faces && passes < MAX_PASSES {
        let a = adj
            .take()
            .unwrap_or_else(|| Adjacency::build(st.pos.len(), &st.tri));
        passes += 1;
        lap(6, &mut tm);
        let nv = st.pos.len();
        let blocks = nv.div_ceil(BLOCK);
        let block_candidates = |b: usize| st.candidates(&a, b, bound, cache.as_ref());
        let cands: Vec<Candidate> = if nv >= PARALLEL_MIN {
            (0..blocks)
                .into_par_iter()
                .map(block_candidates)
                .collect::<Vec<_>>()
                .concat()
        } else {
            (0..blocks).flat_map(block_candidates).collect()
        };
        lap(7, &mut tm);
        if cands.is_empty() {
            break;
        }
        // This pass considers the cheapest share of the candidates: a greedy order's first steps, taken
        // in parallel (past the target, the chosen are cut in key order below).
        let share = (cands.len() as f64 * PASS_SHARE).ceil() as usize;
        let needed = (st.tri.len() - opts.target_faces).div_ceil(2);
        let mut take = share.min(needed).clamp(1, cands.len());
        let keys: Vec<u64> = cands
            .iter()
            .enumerate()
            .map(|(i, c)| ((c.cost as f32).to_bits() as u64) << 32 | scramble(i as u32) as u64)
            .collect();
        let want = st.tri.len() - opts.target_faces;
        // When every considered candidate is invalid, consider four times as many, up to all of them.
        let mut chosen = loop {
            let nth = {
                let mut k = keys.clone();
                let (_, nth, _) = k.select_nth_unstable(take - 1);
                *nth
            };
            // Every candidate within SLACK of the take-th cost (all ties of a flat region at once): the
            // cheap edges blocked this pass wait for the next one instead of costlier ones going first.
            let limit_cost = (f32::from_bits((nth >> 32) as u32) * SLACK) as f64;
            let limit = ((limit_cost as f32).to_bits() as u64) << 32 | u32::MAX as u64;
            let mut active: Vec<u32> = (0..cands.len() as u32)
                .filter(|&i| keys[i as usize] <= limit)
                .collect();
            lap(8, &mut tm);
            let chosen = independent_collapses(
                &st,
                &a,
                &cands,
                &keys,
                &mut active,
                limit_cost.min(bound),
                want,
            );
            lap(9, &mut tm);
            if !chosen.is_empty() || take == cands.len() {
                break chosen;
            }
            take = (take * 4).min(cands.len());
        };
        if timing {
            eprintln!(
                "simplify pass {passes}: {} triangles, {} candidates, {take} considered, {} chosen, \
                 error up to {:.3e}",
                st.tri.len(),
                cands.len(),
                chosen.len(),
                chosen.iter().map(|c| c.1.cost).fold(0.0, f64::max).sqrt()
            );
        }
        // Past the target, only the cheapest collapses of this pass are made (in key order).
        let mut removed = 0usize;
        let cut = chosen
            .iter()
            .position(|c| {
                let done = removed >= want;
                removed += c.2 as usize;
                done
            })
            .unwrap_or(chosen.len());
        chosen.truncate(cut);
        if chosen.is_empty() {
            break;
        }
        // K: remove → keep; the survivors move and take the sum of the quadrics.
        let mut remap: Vec<u32> = (0..nv as u32).collect();
        let mut dirty = vec![false; nv];
        let mut removed_vertices = 0;
        for (_, c, _) in &chosen {
            // A seam collapse and its twin: the same merge on both sides, onto the same point.
            let twin = c.twin.map(|[r, k]| (r, k));
            for (remove, keep) in [(c.remove, c.keep)].into_iter().chain(twin) {
                remap[remove as usize] = keep;
                dirty[keep as usize] = true;
                dirty[remove as usize] = true;
                st.pos[keep as usize] = c.to;
                let qr = st.quad[remove as usize];
                st.quad[keep as usize].add(&qr);
                let nr = st.normal[remove as usize];
                st.normal[keep as usize] += nr;
                removed_vertices += 1;
            }
            error2 = error2.max(c.cost);
        }
        collapses += removed_vertices;
        let Adjacency { border, .. } = a;
        let allow = opts.allow_topology;
        // B' = K·B: one gather of the index buffer; triangles that lost a corner go.
        let gather = |t: &[u32; 3]| {
            let u = t.map(|x| remap[x as usize]);
            (u[0] != u[1] && u[1] != u[2] && u[0] != u[2]).then_some(u)
        };
        st.tri = if st.tri.len() >= PARALLEL_MIN {
            st.tri.par_iter().filter_map(gather).collect()
        } else {
            st.tri.iter().filter_map(gather).collect()
        };
        if allow {
            dedup_triangles(&mut st.tri);
        }
        lap(10, &mut tm);
        // Compact the vertex arrays once half of them are gone, so a pass costs the live mesh only.
        dead += removed_vertices;
        let (mut cands, mut dirty, mut border, mut nv) = (cands, dirty, border, nv);
        if dead * 2 > nv {
            let new_id = compact(&mut st, &mut ids);
            dead = 0;
            // The renumbering keeps the order, so the candidates, sorted by (a, b), stay sorted.
            cands.retain_mut(|c| {
                let (a, b) = (new_id[c.a as usize], new_id[c.b as usize]);
                (c.a, c.b) = (a, b);
                a != u32::MAX && b != u32::MAX
            });
            let keep = |v: &[bool]| -> Vec<bool> {
                v.iter()
                    .zip(&new_id)
                    .filter(|(_, &k)| k != u32::MAX)
                    .map(|(&x, _)| x)
                    .collect()
            };
            dirty = keep(&dirty);
            border = keep(&border);
            nv = st.pos.len();
        }
        // (With `allow_topology` duplicates are removed, which changes edges far from the survivors.)
        cache = (!allow).then(|| {
            let mut ptr = vec![0u32; nv + 1];
            for c in &cands {
                ptr[c.a as usize + 1] += 1;
            }
            for v in 0..nv {
                ptr[v + 1] += ptr[v];
            }
            Cache {
                cands,
                ptr,
                dirty,
                border,
            }
        });
    }
    lap(11, &mut tm);
    let _ = compact(&mut st, &mut ids);
    if timing {
        let stages: Vec<String> = STAGES
            .iter()
            .zip(tm)
            .map(|(n, t)| format!("{n} {t:.1}"))
            .collect();
        eprintln!("simplify ms: {} ({passes} passes)", stages.join(", "));
    }
    Simplified {
        positions: st.pos,
        triangles: st.tri,
        source_vertex: ids,
        error: error2.sqrt(),
        collapses,
        passes,
        locked_vertices,
        pruned_triangles,
        degenerate_input,
    }
}

/// A bijection of u32 (odd multiplications and xor-shifts): ties of cost are broken in a scattered but
/// fixed order. Breaking them by edge index would make the local minima of a flat region (every cost 0)
/// a sweep front, one row of collapses per pass; keys stay unique, as the selection needs.
fn scramble(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// Picks non-interfering collapses among the `active` candidates (indices into `cands`, increasing):
/// rounds of local minima (an edge whose key is the least over the edges touching its endpoints' closed
/// one-rings), each checked for validity; a valid one blocks its closed one-rings for the rest of the
/// pass, an invalid one leaves. Stops when `faces` triangles would be removed, nothing is active, or after
/// [`MAX_ROUNDS`] rounds. Returns (key, collapse, triangles removed) in key order.
fn independent_collapses(
    st: &State,
    adj: &Adjacency,
    cands: &[Candidate],
    keys: &[u64],
    active: &mut Vec<u32>,
    bound: f64,
    faces: usize,
) -> Vec<(u64, Collapse, u8)> {
    let nv = st.pos.len();
    let m1: Vec<AtomicU64> = (0..nv).map(|_| AtomicU64::new(u64::MAX)).collect();
    let blocked: Vec<AtomicBool> = (0..nv).map(|_| AtomicBool::new(false)).collect();
    let mut chosen: Vec<(u64, Collapse, u8)> = Vec::new();
    let mut removed = 0usize;
    for _ in 0..MAX_ROUNDS {
        if active.is_empty() || removed >= faces {
            break;
        }
        // Small rounds run on this thread: waking the pool costs more than they do.
        let par = active.len() >= PARALLEL_MIN;
        let least = |&i: &u32| {
            let c = &cands[i as usize];
            let k = keys[i as usize];
            let (t, n) = st.touched(adj, c);
            for &v in &t[..n] {
                m1[v as usize].fetch_min(k, Ordering::Relaxed);
            }
        };
        if par {
            active.par_iter().for_each(least);
        } else {
            active.iter().for_each(least);
        }
        let m2 = |v: u32| {
            let (nbs, _) = adj.neighbours(v);
            nbs.iter()
                .fold(m1[v as usize].load(Ordering::Relaxed), |m, &u| {
                    m.min(m1[u as usize].load(Ordering::Relaxed))
                })
        };
        // The local minima, each checked for validity.
        let minimum = |&i: &u32| -> Option<(u32, Option<Collapse>)> {
            let c = &cands[i as usize];
            let k = keys[i as usize];
            // The least at every end first (cheap), then over the closed one-rings.
            let (t, n) = st.touched(adj, c);
            (t[..n]
                .iter()
                .all(|&v| m1[v as usize].load(Ordering::Relaxed) == k)
                && t[..n].iter().all(|&v| m2(v) == k))
            .then(|| (i, st.validate(adj, c, bound)))
        };
        let minima: Vec<(u32, Option<Collapse>)> = if par {
            active.par_iter().filter_map(minimum).collect()
        } else {
            active.iter().filter_map(minimum).collect()
        };
        for &(i, v) in &minima {
            let Some(col) = v else { continue };
            let c = &cands[i as usize];
            let (t, n) = st.touched(adj, c);
            for &e in &t[..n] {
                blocked[e as usize].store(true, Ordering::Relaxed);
                for &u in adj.neighbours(e).0 {
                    blocked[u as usize].store(true, Ordering::Relaxed);
                }
            }
            // (A seam pair removes a triangle on each side.)
            let faces = c.faces * if col.twin.is_some() { 2 } else { 1 };
            chosen.push((keys[i as usize], col, faces));
            removed += faces as usize;
        }
        // Minima leave (valid or not), and so do the edges the chosen ones blocked; m1 is reset for the
        // next round on the way (`active` and `minima` are both in increasing order).
        let mut next_minimum = minima.iter().map(|m| m.0).peekable();
        active.retain(|&i| {
            let c = &cands[i as usize];
            let (t, n) = st.touched(adj, c);
            for &v in &t[..n] {
                m1[v as usize].store(u64::MAX, Ordering::Relaxed);
            }
            if next_minimum.peek() == Some(&i) {
                next_minimum.next();
                return false;
            }
            !t[..n]
                .iter()
                .any(|&v| blocked[v as usize].load(Ordering::Relaxed))
        });
    }
    chosen.sort_unstable_by_key(|c| c.0);
    chosen
}

/// Renumbers the referenced vertices in order and drops the others (between passes, and at the end:
/// the output keeps the referenced vertices in the order of their input ids). Returns every old id's
/// new one (`u32::MAX` for the dropped).
fn compact(st: &mut State, ids: &mut Vec<u32>) -> Vec<u32> {
    let n = st.pos.len();
    let mut used = vec![false; n];
    for t in &st.tri {
        for &v in t {
            used[v as usize] = true;
        }
    }
    let mut new_id = vec![u32::MAX; n];
    let mut k = 0u32;
    for v in 0..n {
        if used[v] {
            new_id[v] = k;
            k += 1;
        }
    }
    fn kept<T: Copy>(v: &[T], used: &[bool]) -> Vec<T> {
        v.iter()
            .zip(used)
            .filter(|(_, &u)| u)
            .map(|(x, _)| *x)
            .collect()
    }
    st.pos = kept(&st.pos, &used);
    st.quad = kept(&st.quad, &used);
    st.normal = kept(&st.normal, &used);
    st.flags = kept(&st.flags, &used);
    st.twin = kept(&st.twin, &used)
        .into_iter()
        .map(|t| {
            if t == NO_TWIN {
                NO_TWIN
            } else {
                new_id[t as usize]
            }
        })
        .collect();
    *ids = kept(ids, &used);
    for t in st.tri.iter_mut() {
        *t = t.map(|v| new_id[v as usize]);
    }
    new_id
}

/// Removes triangles over the same three vertices as an earlier one (any orientation).
fn dedup_triangles(tri: &mut Vec<[u32; 3]>) {
    let mut seen = std::collections::HashSet::with_capacity(tri.len());
    tri.retain(|t| {
        let mut s = *t;
        s.sort_unstable();
        seen.insert(s)
    });
}

/// Plane quadrics at every corner (weighted by √area), plus boundary-edge quadrics (seam edges — both
/// ends with a twin — at [`SEAM_WEIGHT`]); summed per vertex over its faces in face order (deterministic).
fn initial_quadrics(
    pos: &[DVec3],
    tri: &[[u32; 3]],
    adj: &Adjacency,
    twin: &[u32],
) -> Vec<Quadric> {
    let face_q: Vec<Quadric> = tri
        .par_iter()
        .map(|t| {
            let p = t.map(|v| pos[v as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let l = n.length();
            if l == 0.0 || !l.is_finite() {
                return Quadric::default();
            }
            let u = n / l;
            Quadric::plane(u, -u.dot(p[0]), (0.5 * l).sqrt())
        })
        .collect();
    (0..pos.len() as u32)
        .into_par_iter()
        .map(|v| {
            let mut q = Quadric::default();
            for &f in adj.faces(v) {
                q.add(&face_q[f as usize]);
            }
            let (nbs, nbf) = adj.neighbours(v);
            for (k, &u) in nbs.iter().enumerate() {
                if nbf[k] != 1 {
                    continue;
                }
                // The one triangle on the boundary edge (v, u).
                let f = adj
                    .faces(v)
                    .iter()
                    .copied()
                    .find(|&f| tri[f as usize].contains(&u));
                let Some(f) = f else { continue };
                let t = tri[f as usize];
                let p = t.map(|x| pos[x as usize]);
                let n = (p[1] - p[0]).cross(p[2] - p[0]);
                let e = pos[u as usize] - pos[v as usize];
                let m = e.cross(n);
                let l = m.length();
                if l == 0.0 || !l.is_finite() {
                    continue;
                }
                let m = m / l;
                let seam = twin[v as usize] != NO_TWIN && twin[u as usize] != NO_TWIN;
                let weight = if seam { SEAM_WEIGHT } else { BOUNDARY_WEIGHT } * e.length();
                let origin = pos[v as usize];
                q.add(&Quadric::plane(m, -m.dot(origin), weight));
                // The triangle's plane, counted in the sum but not in the normalisation: moving off the
                // surface at a border (or a seam) costs the edge's weight too.
                let face = n / n.length();
                let mut along = Quadric::plane(face, -face.dot(origin), weight);
                along.w = 0.0;
                q.add(&along);
            }
            q
        })
        .collect()
}

/// The seams: pairs of vertices at the same position (bit for bit) whose fans are half-discs meeting along
/// the seam, each vertex's two boundary neighbours at the positions of its twin's two. A pair collapses
/// only together with its twin edge (both sides of the seam at once, onto the same position), so the seam
/// stays closed. Vertices sharing their position with two or more others (seam ends, corners where
/// several seams meet) and pairs that do not match are locked. Returns every vertex's twin.
fn seam_twins(pos: &[DVec3], adj: &Adjacency, referenced: &[bool], flags: &mut [u8]) -> Vec<u32> {
    let n = pos.len();
    let key = |v: u32| pos[v as usize].to_array().map(f64::to_bits);
    let mut order: Vec<u32> = (0..n as u32).filter(|&v| referenced[v as usize]).collect();
    order.par_sort_unstable_by_key(|&v| (key(v), v));
    let mut twin = vec![NO_TWIN; n];
    let mut i = 0;
    while i < order.len() {
        let mut j = i + 1;
        while j < order.len() && key(order[j]) == key(order[i]) {
            j += 1;
        }
        match j - i {
            1 => {}
            2 => {
                twin[order[i] as usize] = order[i + 1];
                twin[order[i + 1] as usize] = order[i];
            }
            _ => {
                for &v in &order[i..j] {
                    flags[v as usize] |= LOCKED;
                }
            }
        }
        i = j;
    }
    // The boundary neighbours' positions, sorted: a seam pair's must be the same.
    let border_keys = |v: u32| -> Option<[[u64; 3]; 2]> {
        let (nbs, nbf) = adj.neighbours(v);
        let mut found = nbs
            .iter()
            .zip(nbf)
            .filter(|(_, &f)| f == 1)
            .map(|(&u, _)| key(u));
        let (x, y) = (found.next()?, found.next()?);
        found
            .next()
            .is_none()
            .then(|| if x <= y { [x, y] } else { [y, x] })
    };
    for v in 0..n as u32 {
        let w = twin[v as usize];
        if w == NO_TWIN || w < v {
            continue;
        }
        let paired = flags[v as usize] & LOCKED == 0
            && flags[w as usize] & LOCKED == 0
            && !adj.neighbours(v).0.contains(&w)
            && border_keys(v).is_some()
            && border_keys(v) == border_keys(w);
        if !paired {
            twin[v as usize] = NO_TWIN;
            twin[w as usize] = NO_TWIN;
            flags[v as usize] |= LOCKED;
            flags[w as usize] |= LOCKED;
        }
    }
    for (fl, &t) in flags.iter_mut().zip(&twin) {
        if t != NO_TWIN {
            *fl |= SEAM;
        }
    }
    twin
}

/// Drops the vertex-connected pieces whose bounding-box diagonal is at most `fraction` of the mesh's.
fn prune_small_pieces(pos: &[DVec3], tri: Vec<[u32; 3]>, fraction: f64) -> Vec<[u32; 3]> {
    let n = pos.len();
    let mut sets = super::topology::UnionFind::new(n);
    for t in &tri {
        sets.union(t[0], t[1]);
        sets.union(t[0], t[2]);
    }
    let mut lo = vec![DVec3::splat(f64::INFINITY); n];
    let mut hi = vec![DVec3::splat(f64::NEG_INFINITY); n];
    let (mut all_lo, mut all_hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for t in &tri {
        for &v in t {
            let r = sets.find(v) as usize;
            lo[r] = lo[r].min(pos[v as usize]);
            hi[r] = hi[r].max(pos[v as usize]);
            all_lo = all_lo.min(pos[v as usize]);
            all_hi = all_hi.max(pos[v as usize]);
        }
    }
    let limit = fraction * (all_hi - all_lo).length();
    tri.into_iter()
        .filter(|t| {
            let r = sets.find(t[0]) as usize;
            (hi[r] - lo[r]).length() > limit
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: u32) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                p.push(DVec3::new(i as f64, j as f64, 0.0));
            }
        }
        let mut t = Vec::new();
        let id = |i: u32, j: u32| j * (n + 1) + i;
        for j in 0..n {
            for i in 0..n {
                t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        (p, t)
    }

    #[test]
    fn a_flat_grid_reduces_without_error_and_keeps_its_border() {
        let (p, t) = grid(10);
        let s = simplify(
            &p,
            &t,
            &SimplifyOptions {
                target_faces: 20,
                ..Default::default()
            },
        );
        assert!(s.triangles.len() <= 40, "{}", s.triangles.len());
        assert!(s.error < 1e-9);
        // Every output vertex stays in the square and the square's corners remain.
        for c in [
            DVec3::ZERO,
            DVec3::new(10.0, 0.0, 0.0),
            DVec3::new(10.0, 10.0, 0.0),
        ] {
            assert!(s.positions.iter().any(|&q| q.distance(c) < 1e-9), "{c}");
        }
    }

    #[test]
    fn split_at_offsets_covers_the_tail() {
        let mut v = [0, 1, 2, 3, 4, 5];
        let parts = split_at_offsets(&mut v, &[1, 3]);
        assert_eq!(parts.len(), 2);
        assert_eq!(parts[0], [1, 2]);
        assert_eq!(parts[1], [3, 4, 5]);
    }

    #[test]
    fn a_bowtie_fan_is_not_manifold() {
        let tri = [[0, 1, 2], [0, 3, 4]];
        assert!(!fan_is_manifold(0, &[0, 1], &tri));
        assert!(fan_is_manifold(1, &[0], &tri));
        let tri = [[0, 1, 2], [0, 2, 3], [0, 3, 1]];
        assert!(fan_is_manifold(0, &[0, 1, 2], &tri));
    }
}
