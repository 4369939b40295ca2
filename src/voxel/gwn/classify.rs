//! Labels the grid with the fractional term: for every voxel outside the near zone, an integer k with
//! w_X ∈ (k − ½, k + ½) there, found box by box from 32³ down to single voxels.
//!
//! A box is labelled when an interval for w_X over the ball round its voxel centres lies strictly between
//! two half-integers; its voxels then need no more (k = 0: the rasterized grid stands; k ≠ 0: their
//! crossing count decides, `super::cpu::relabel`). Otherwise its 2³ children are tried, down to cells of
//! 2³ voxels, which are finished voxel by voxel: each voxel starts from the cell's interval (the far fields
//! at the voxel, every kept node's share over the cell) and replaces the widest shares by their values at
//! the voxel until it is labelled, so a voxel beside one cap triangle evaluates that triangle and not the
//! cell's whole list. A voxel no bound labels goes to the direct evaluation (`super::direct`).
//!
//! The interval is a dual traversal, as in a fast multipole method: each box inherits from its parent the
//! interval of the nodes already accepted (valid over the parent's ball, hence over its own) and the list
//! of nodes still open, and re-examines only those: a node far enough for this box's radius is accepted
//! (the small caps' expansion into the box's quadratic model, or a ribbon node's bound), one too close for a
//! box no larger than it is opened, and the rest are passed down. Large caps (rim of 32 voxels or more)
//! take another road: their value at the box centre, moved by at most r·(the Biot–Savart bound of their
//! rim), so a box above the middle of a wide hole or panel is labelled however wide it is; their fans are
//! kept whole (a point near one sums its few triangles exactly). Where the large caps are few (at most
//! [`LINEAR_MAX_TRIANGLES`] triangles) and the small caps leave room, a box takes them as a linear model
//! instead: their value at the centre found tightly, plus the exact Biot–Savart gradient of the rim's near
//! edges, within r²·Σ|e|/(d_e − r)³ of the truth over the ball (`EdgeTree::linear`). The box's interval then
//! moves by the gradient's own length, and a cell's voxels read the caps at the model's error before falling
//! back on their kept triangles: near the middle of a wide hole or panel, where w stays within a few hundredths
//! of ½ for many voxels (the chair's seat), this settles boxes and voxels that the rim's gradient bound could
//! not (the chair at 256³: 688k voxels one by one → 189k, labelling 3.4 s → 1.5–2.0 s, same grid).
//!
//! Cost: a box costs its inherited open list (tens of nodes) plus the large caps' traversal; boxes are
//! visited only where w_X comes within the bounds' width of a half-integer, which is near the caps and the
//! ribbons, so the work follows the fractional term's geometry and not the number of loops or pieces.
//! Boxes are independent: rayon over the children of every split. A node accepted into a box's far field
//! costs its expansion's value, gradient and Hessian once (`Tree::local_share`, about twice the gradient's
//! arithmetic); a voxel then reads the quadratic in a few dozen operations whatever was accepted above it.
//! The large caps' interval is a loose traversal (θ 0.5): with 300 overlapping caps near every box it is
//! still a tree walk per box, which is why it is loose. Measured on the inputs that attack this stage, in
//! `gregvox bench --suite gwn` (`gwn_stress`, `gwn_worst`): a third of the bunny removed (11,257 loops), 300
//! open shells, the unwelded soup, a 10⁶-edge open tube and the bunny with 5 % removed at 1024³.
//!
//! Invariants: near-zone voxels are never labelled here (they are all decided directly, whatever a box
//! says); `nu` is the fractional term's distance to any voxel outside the zone; the stage stops at the
//! deadline and past the memory budget with the caller's errors.
use super::edges::EdgeTree;
use super::kernel::FOUR_PI;
use super::tree::{
    adaptive, packed_norm, packed_times, refine_from, Accept, Ball, LocalShare, Scratch, Tree,
};
use super::zone::{centre, linear};
use crate::error::{Error, Result};
use crate::voxel::grid::GridFrame;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Edge, in voxels, of the coarsest boxes.
pub const TOP: u32 = 32;
/// Edge of a cell, the smallest box.
pub const CELL: u32 = 2;
/// A small cap's node is accepted for a box when (ρ + r) ≤ θ·D … (0.4 since the caps' truncations use their
/// own moments, `Tree::tighten_tails`: fewer expansions per box for the same decisions; at 256³, whole
/// processes, θ 0.3 → 0.4: a third of the bunny removed 7.1 → 6.1 s, 300 open shells 12.3 → 9.9 s, the
/// unwelded soup 0.89 → 0.73 s, the bunny with 5 % removed 1.05 → 1.03 s, the teapot 0.29 → 0.31 s, the
/// same grids.)
pub const THETA: f64 = 0.4;
/// … and r ≤ SPREAD·g (its variation over the ball stays a small part of its A/g²).
pub const SPREAD: f64 = 0.3;
/// Triangles per leaf of the caps' trees.
pub const CAP_LEAF: usize = 2;
/// A node kept at a cell is expanded at each voxel when ρ ≤ POINT_THETA·(D − r).
pub const POINT_THETA: f64 = 0.5;
/// Bound-only acceptance of a node (steradians).
pub const BOUND_EPS: f64 = 1e-3;
/// Bound-only acceptance of a ribbon node: ribbons are only ever bounded, and there are many.
pub const THIN_EPS: f64 = 3e-3;
/// How the large caps' value at a box centre accepts nodes. Loose on purpose: the interval is tried at every
/// box and cell near a large cap, and a tight one cost more than the voxels it spared (300 overlapping open
/// shells at 256³: 26 s with θ 0.3, ε 1e-4; 13 s with these, the same grid).
pub const LARGE_ACCEPT: Accept = Accept {
    theta: 0.5,
    eps: 3e-2,
};
/// The large caps' value at a cell centre for their linear model (`Fractional::large_linear`).
pub const TIGHT_ACCEPT: Accept = Accept {
    theta: 0.3,
    eps: 1e-4,
};
/// The large caps' linear model is tried at a box whose small caps' interval is narrower than this
/// (steradians).
pub const LINEAR_BELOW: f64 = 2.0;
/// The linear model is made only when the large caps have at most this many triangles: its value at a box
/// centre is a tight traversal of all of them, which with hundreds of caps round every box cost more than the
/// voxels it spared (300 open shells at 256³: labelling 14–19 s without the model, 28–29 s with it; the
/// chair's 108 triangles: 3.4 s → 1.5 s).
pub const LINEAR_MAX_TRIANGLES: usize = 1024;
/// A rim node whose whole variation over a cell is at most this (steradians) is bounded, not summed.
pub const LINEAR_EPS: f64 = 1e-3;
/// The rim's gradient bound over a ball of radius r accepts a node's bound b when r·b ≤ this (steradians).
pub const RIM_EPS: f64 = 0.1;
/// Triangles per leaf of the large caps' tree (whole fan triangles).
pub const LARGE_LEAF: usize = 4;
/// A near triangle whose bound at a voxel is at most this (steradians) is taken as ± the bound.
pub const TRI_EPS: f64 = 1e-4;
/// Slack on the half-integers, in units of w (far above the rounding the bounds already cover).
pub const SLACK: f64 = 1e-9;
/// Bytes one listed voxel costs (its index and label).
pub const LISTED_BYTES: u64 = 16;

/// The fractional term X, as the queries need it: the small caps with their expansions, the large caps
/// with their rim (for the gradient), the thin ribbons (bounded, never expanded). Caps are cut into
/// triangles of a few voxels.
#[derive(Default)]
pub struct Fractional {
    pub caps: Tree,
    /// The large caps (their value at a point; the rim bounds its gradient).
    pub large: Tree,
    pub rim: EdgeTree,
    pub ribbons: Tree,
}

/// The large caps over a cell as a linear model ([`Fractional::large_linear`]).
#[derive(Clone, Copy, Debug)]
struct LargeLinear {
    value: f64,
    gradient: [f64; 3],
    at: [f64; 3],
    err: f64,
}

impl LargeLinear {
    fn value_at(&self, q: [f64; 3]) -> f64 {
        self.value
            + (0..3)
                .map(|k| self.gradient[k] * (q[k] - self.at[k]))
                .sum::<f64>()
    }
}

/// Per-thread scratch.
#[derive(Default)]
pub struct Scratches {
    pub caps: Scratch,
    stack: Vec<u32>,
}

impl Fractional {
    pub fn is_empty(&self) -> bool {
        self.caps.is_empty() && self.large.is_empty() && self.ribbons.is_empty()
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        self.caps.bytes() + self.large.bytes() + self.rim.bytes() + self.ribbons.bytes()
    }

    /// The large caps over `ball`: their value at the centre moved by at most r·(rim bound); `None` when a
    /// large cap comes within the ball.
    fn large_interval(&self, ball: &Ball, s: &mut Scratches) -> Option<(f64, f64)> {
        if self.large.is_empty() {
            return Some((0.0, 0.0));
        }
        let (lo, hi) = self
            .large
            .interval_at(ball.c, ball.r, &LARGE_ACCEPT, &mut s.caps)?;
        let moved = if ball.r > 0.0 {
            ball.r
                * self
                    .rim
                    .gradient(ball.c, ball.r, RIM_EPS / ball.r, &mut s.stack)
        } else {
            0.0
        };
        moved.is_finite().then_some((lo - moved, hi + moved))
    }

    /// The large caps over a cell's `ball` as a linear model: `(value at the centre, gradient, error)`, the
    /// value found tightly ([`TIGHT_ACCEPT`]) and the gradient from the rim's near edges
    /// ([`EdgeTree::linear`]), so that the caps at a voxel q of the ball lie within `error` of
    /// value + gradient·(q − centre). `None` when a large cap comes within the ball.
    fn large_linear(&self, ball: &Ball, s: &mut Scratches) -> Option<LargeLinear> {
        let (lo, hi) = self
            .large
            .interval_at(ball.c, ball.r, &TIGHT_ACCEPT, &mut s.caps)?;
        let (g, b) = self.rim.linear(ball.c, ball.r, LINEAR_EPS, &mut s.stack)?;
        let err = 0.5 * (hi - lo) + b;
        err.is_finite().then_some(LargeLinear {
            value: 0.5 * (lo + hi),
            // The rim holds the mesh's boundary edges, which run against the caps' own boundary (the caps
            // close the mesh).
            gradient: g.map(|x| -x),
            at: ball.c,
            err,
        })
    }

    /// Decides at point `q` (see [`adaptive`]) over every part of X together.
    pub fn adaptive<T>(
        &self,
        q: [f64; 3],
        nu: f64,
        accept: &Accept,
        decide: impl FnMut(f64, f64) -> Option<T>,
        s: &mut Scratches,
    ) -> Option<T> {
        adaptive(
            &[&self.caps, &self.large, &self.ribbons],
            q,
            nu,
            accept,
            decide,
            &mut s.caps,
        )
    }
}

/// The integer k with [lo, hi]/4π strictly inside (k − ½, k + ½), if any.
pub fn label(lo: f64, hi: f64) -> Option<i32> {
    let (lo, hi) = (lo / FOUR_PI, hi / FOUR_PI);
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let k = (0.5 * (lo + hi)).round();
    (lo > k - 0.5 + SLACK && hi < k + 0.5 - SLACK && k.abs() < 1e9).then_some(k as i32)
}

/// What the labelling found.
#[derive(Clone, Debug, Default)]
pub struct Labels {
    /// Boxes (voxels `[lo, hi)`) whose voxels outside the zone all have label k ≠ 0.
    pub boxes: Vec<([u32; 3], [u32; 3], i32)>,
    /// Single voxels with label k ≠ 0.
    pub voxels: Vec<([u32; 3], i32)>,
    /// Voxels no bound labelled (linear indices, sorted).
    pub undecided: Vec<u64>,
    /// Boxes (cells included) whose interval was computed.
    pub boxes_evaluated: u64,
    /// Voxels evaluated one by one in cells.
    pub voxels_evaluated: u64,
}

impl Labels {
    fn merge(mut self, other: Labels) -> Labels {
        self.boxes.extend(other.boxes);
        self.voxels.extend(other.voxels);
        self.undecided.extend(other.undecided);
        self.boxes_evaluated += other.boxes_evaluated;
        self.voxels_evaluated += other.voxels_evaluated;
        self
    }
}

/// The limits the stage runs under.
pub struct Limits<'a> {
    pub deadline: Option<std::time::Instant>,
    /// The time limit as given (for the message).
    pub seconds: f64,
    /// Listed voxels allowed (memory budget / [`LISTED_BYTES`]).
    pub max_listed: u64,
    pub expired: &'a AtomicBool,
}

impl Limits<'_> {
    /// Whether the deadline has passed (and says so to every thread).
    pub fn expired(&self) -> bool {
        if self.expired.load(Ordering::Relaxed) {
            return true;
        }
        if self
            .deadline
            .is_some_and(|d| std::time::Instant::now() >= d)
        {
            self.expired.store(true, Ordering::Relaxed);
            return true;
        }
        false
    }
}

/// The voxels `[lo, hi)` of the box `b` of `edge` voxels, clipped to the grid.
fn box_range(frame: &GridFrame, b: [u32; 3], edge: u32) -> ([u32; 3], [u32; 3]) {
    (
        b.map(|x| x * edge),
        std::array::from_fn(|a| (b[a] * edge + edge).min(frame.dims[a])),
    )
}

/// The ball round the centres of the voxels `[lo, hi)`.
fn ball_of(frame: &GridFrame, lo: [u32; 3], hi: [u32; 3], nu: f64) -> Ball {
    let a = centre(frame, lo);
    let b = centre(frame, [hi[0] - 1, hi[1] - 1, hi[2] - 1]);
    let c = std::array::from_fn(|k| 0.5 * (a[k] + b[k]));
    let r = 0.5 * ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt();
    Ball {
        c,
        r: r * (1.0 + 1e-12),
        nu,
    }
}

/// The far field a box passes to its children: value, gradient and Hessian at `at`, and a bound on how far
/// the field can depart from that quadratic anywhere in the box (truncations, the Taylor remainder, and the
/// bounds of the nodes taken as bounds). Moved to a child's centre exactly. Quadratic rather than linear
/// because the remainder is what a cell inherits: a linear model's ½r²·6A/g⁴ was most of a cell's error near
/// a surface strewn with holes (1.1 of 1.4 sr on average on a third of the bunny at 256³), and every voxel
/// whose w came within it of ½ went on to the direct evaluation.
#[derive(Clone, Copy, Debug, Default)]
struct Local {
    value: f64,
    gradient: [f64; 3],
    /// Packed as `tree::PACKED`.
    hessian: [f64; 6],
    at: [f64; 3],
    err: f64,
}

impl Local {
    fn value_at(&self, q: [f64; 3]) -> f64 {
        let d: [f64; 3] = std::array::from_fn(|k| q[k] - self.at[k]);
        let hd = packed_times(&self.hessian, d);
        self.value
            + (0..3)
                .map(|k| (self.gradient[k] + 0.5 * hd[k]) * d[k])
                .sum::<f64>()
    }

    fn moved_to(&self, c: [f64; 3]) -> Local {
        let d: [f64; 3] = std::array::from_fn(|k| c[k] - self.at[k]);
        let hd = packed_times(&self.hessian, d);
        Local {
            value: self.value_at(c),
            gradient: std::array::from_fn(|k| self.gradient[k] + hd[k]),
            at: c,
            ..*self
        }
    }

    /// The interval over a ball of radius `r` round `at`.
    fn over(&self, r: f64) -> (f64, f64) {
        let spread =
            super::kernel::norm(self.gradient) * r + 0.5 * packed_norm(&self.hessian) * r * r;
        (
            self.value - spread - self.err,
            self.value + spread + self.err,
        )
    }

    fn add(&mut self, share: &LocalShare) {
        self.value += share.value;
        for (lg, gk) in self.gradient.iter_mut().zip(share.gradient) {
            *lg += gk;
        }
        for (lh, hk) in self.hessian.iter_mut().zip(share.hessian) {
            *lh += hk;
        }
        self.err += share.err;
    }
}

/// The walk's shared state.
struct Walk<'a> {
    frame: &'a GridFrame,
    x: &'a Fractional,
    nu: f64,
    zone: &'a [u64],
    limits: &'a Limits<'a>,
    listed: AtomicU64,
    over_budget: AtomicBool,
    params: Params,
}

/// Labels every voxel of `frame` outside `zone` (sorted linear indices) with the fractional term `x`,
/// whose triangles lie at least `nu` from any such voxel.
pub fn classify(
    frame: &GridFrame,
    x: &Fractional,
    nu: f64,
    zone: &[u64],
    limits: &Limits,
) -> Result<Labels> {
    if x.is_empty() {
        return Ok(Labels::default());
    }
    let mut roots = Vec::new();
    for (tree, tag) in [(&x.caps, SMALL), (&x.large, LARGE), (&x.ribbons, RIBBON)] {
        if !tree.is_empty() {
            assert!(tree.nodes.len() < INDEX as usize, "a tree of 2³⁰ nodes");
            roots.push(tag);
        }
    }
    let walk = Walk {
        frame,
        x,
        nu,
        zone,
        limits,
        listed: AtomicU64::new(0),
        over_budget: AtomicBool::new(false),
        params: params(),
    };
    let dims = frame.dims.map(|d| d.div_ceil(TOP));
    let tops: Vec<[u32; 3]> = (0..dims[2])
        .flat_map(|z| (0..dims[1]).flat_map(move |y| (0..dims[0]).map(move |x| [x, y, z])))
        .collect();
    let mut labels = tops
        .par_iter()
        .map(|&b| walk.visit(b, TOP, [Local::default(); 2], &roots))
        .reduce(Labels::default, Labels::merge);
    if limits.expired() {
        return Err(Error::Timeout {
            seconds: limits.seconds,
            stage: "labelling the grid with the fractional term".into(),
        });
    }
    if walk.over_budget.load(Ordering::Relaxed) {
        return Err(Error::Budget {
            what: format!(
                "the fractional term of the winding number: more than {} voxels to resolve one by one",
                limits.max_listed
            ),
            detail: "the generalized winding number's memory budget (--gwn-budget MIB, \
                     VoxelizeOptions::gwn_budget; or --rule winding, or a coarser grid)"
                .into(),
        });
    }
    labels.undecided.par_sort_unstable();
    Ok(labels)
}

/// Tunable parameters (constants, but read from `GREGVOX_GWN_PARAMS` while tuning).
#[derive(Clone, Copy, Debug)]
struct Params {
    theta: f64,
    spread: f64,
    point_theta: f64,
}

fn params() -> Params {
    let mut p = Params {
        theta: THETA,
        spread: SPREAD,
        point_theta: POINT_THETA,
    };
    if let Ok(v) = std::env::var("GREGVOX_GWN_PARAMS") {
        let f: Vec<f64> = v.split(',').filter_map(|x| x.parse().ok()).collect();
        if f.len() == 3 {
            p = Params {
                theta: f[0],
                spread: f[1],
                point_theta: f[2],
            };
        }
    }
    p
}

/// The tree of a tag: small caps, large caps or ribbons.
const TREE_SHIFT: u32 = 30;
const SMALL: u32 = 0;
const LARGE: u32 = 1 << TREE_SHIFT;
const RIBBON: u32 = 2 << TREE_SHIFT;
const INDEX: u32 = (1 << TREE_SHIFT) - 1;

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratches> = std::cell::RefCell::new(Scratches::default());
}

impl Walk<'_> {
    fn tree_of(&self, tag: u32) -> &Tree {
        match tag & !INDEX {
            SMALL => &self.x.caps,
            LARGE => &self.x.large,
            _ => &self.x.ribbons,
        }
    }

    /// Box `b` of `edge` voxels with the far fields `inherited` (small caps and ribbons; large caps) and the
    /// nodes `open` from its parent.
    fn visit(&self, b: [u32; 3], edge: u32, inherited: [Local; 2], open: &[u32]) -> Labels {
        let mut found = Labels::default();
        if self.limits.expired() || self.over_budget.load(Ordering::Relaxed) {
            return found;
        }
        found.boxes_evaluated = 1;
        let frame = self.frame;
        let (lo, hi) = box_range(frame, b, edge);
        let ball = ball_of(frame, lo, hi, self.nu);
        let cell = edge == CELL;
        let mut local = inherited.map(|l| l.moved_to(ball.c));
        let keep = self.gather(&ball, cell, &mut local, open);
        // The whole box: the far fields over the ball and what was kept, bounded over the ball. The large caps
        // also through their rim, when that is narrower.
        let (small, large, shares) = self.kept_shares(&ball, &local, &keep, cell);
        let ((sl, sh), (mut ll, mut lh)) = (small, large);
        // The large caps' linear model, where it is made, replaces their loose interval (it is tighter, and
        // it settles the boxes that interval would).
        let modelled =
            self.x.large.triangles.len() <= LINEAR_MAX_TRIANGLES && sh - sl < LINEAR_BELOW;
        if !modelled && sh - sl < FOUR_PI && lh - ll > 0.02 * FOUR_PI && !self.x.large.is_empty() {
            if let Some((bl, bh)) =
                SCRATCH.with(|s| self.x.large_interval(&ball, &mut s.borrow_mut()))
            {
                if bh - bl < lh - ll {
                    (ll, lh) = (bl, bh);
                }
            }
        }
        let mut decided = label(sl + ll, sh + lh);
        // The large caps as a linear model over the box, when the small caps leave room for it to settle the
        // box: the model moves by its gradient's own length, not by the rim's bound on any gradient, and a
        // cell's voxels then read the caps' value to the model's error instead of evaluating their kept
        // triangles.
        let mut linear = None;
        if decided.is_none() && !self.x.large.is_empty() && modelled {
            linear = SCRATCH.with(|s| self.x.large_linear(&ball, &mut s.borrow_mut()));
            if let Some(m) = &linear {
                let spread = super::kernel::norm(m.gradient) * ball.r + m.err;
                decided = label(sl + m.value - spread, sh + m.value + spread);
            }
        }
        if let Some(k) = decided {
            if k != 0 {
                found.boxes.push((lo, hi, k));
            }
            return found;
        }
        if cell {
            self.cell_voxels(lo, hi, &local, &keep, &shares, linear, &mut found);
            let added = (found.voxels.len() + found.undecided.len()) as u64;
            if self.listed.fetch_add(added, Ordering::Relaxed) + added > self.limits.max_listed {
                self.over_budget.store(true, Ordering::Relaxed);
            }
            return found;
        }
        let half = edge / 2;
        let cd = frame.dims.map(|d| d.div_ceil(half));
        let children: Vec<[u32; 3]> = (0..8u32)
            .map(|s| {
                [
                    b[0] * 2 + (s & 1),
                    b[1] * 2 + (s >> 1 & 1),
                    b[2] * 2 + (s >> 2),
                ]
            })
            .filter(|c| (0..3).all(|a| c[a] < cd[a]))
            .collect();
        let below = children
            .par_iter()
            .map(|&c| self.visit(c, half, local, &keep))
            .reduce(Labels::default, Labels::merge);
        found.merge(below)
    }

    /// The nodes of `open` examined for `ball`: far ones go into the far fields `local` (as expansions
    /// accepted when the ball's radius is at most the spread times their gap, or as bounds), the rest are
    /// opened or returned (kept) for the ball's voxels or children.
    fn gather(&self, ball: &Ball, cell: bool, local: &mut [Local; 2], open: &[u32]) -> Vec<u32> {
        let p = &self.params;
        let mut keep = Vec::with_capacity(open.len());
        let mut stack = open.to_vec();
        while let Some(tag) = stack.pop() {
            let tree = self.tree_of(tag);
            let thin = tag & !INDEX == RIBBON;
            let part = (tag & !INDEX == LARGE) as usize;
            let i = tag & INDEX;
            let node = &tree.nodes[i as usize];
            let d = super::kernel::norm(crate::voxel::surface::sub(ball.c, node.centre));
            let gap = d - ball.r - node.radius;
            let bound = Tree::node_bound(node, gap, self.nu);
            if bound <= if thin { THIN_EPS } else { BOUND_EPS } {
                local[part].err += bound;
                continue;
            }
            let separated = gap > 0.0 && node.radius + ball.r <= p.theta * d;
            if !thin && separated && ball.r <= p.spread * gap {
                match tree.local_share_below(i, ball, bound) {
                    Some(share) => local[part].add(&share),
                    None => local[part].err += bound,
                }
                continue;
            }
            if !node.is_leaf() && (cell || (!separated && node.radius >= ball.r)) {
                // At a cell every node is opened until it can be expanded at each voxel (or is a leaf).
                let point = gap > 0.0 && node.radius <= p.point_theta * (d - ball.r);
                if !(cell && !thin && point) {
                    let t = tag & !INDEX;
                    stack.push(node.first | t);
                    stack.push((node.first + 1) | t);
                    continue;
                }
            }
            keep.push(tag);
        }
        keep
    }

    /// The intervals (small caps and ribbons; large caps) over `ball` of the far fields and the kept nodes,
    /// and at a cell each kept node's share (value, error) over the ball.
    #[allow(clippy::type_complexity)]
    fn kept_shares(
        &self,
        ball: &Ball,
        local: &[Local; 2],
        keep: &[u32],
        cell: bool,
    ) -> ((f64, f64), (f64, f64), Vec<(f64, f64)>) {
        let (mut sl, mut sh) = local[0].over(ball.r);
        let (mut ll, mut lh) = local[1].over(ball.r);
        // Each kept node's share over the ball, which a cell's voxels start from.
        let mut shares = Vec::with_capacity(if cell { keep.len() } else { 0 });
        for &tag in keep {
            let tree = self.tree_of(tag);
            let node = &tree.nodes[(tag & INDEX) as usize];
            let (mut v, mut e) = tree.share_over(tag & INDEX, ball);
            if node.is_leaf() && e > BOUND_EPS {
                // Triangle by triangle: thin ones by their bound, fat ones exactly at the centre.
                let thin = tag & !INDEX == RIBBON;
                let (mut tv, mut te) = (0.0, 0.0);
                for t in &tree.triangles[node.first as usize..(node.first + node.count) as usize] {
                    if thin {
                        te += t.bound_over(ball);
                    } else {
                        let (a, b) = t.share_over(ball);
                        tv += a;
                        te += b;
                    }
                }
                if te < e {
                    (v, e) = (tv, te);
                }
            }
            if tag & !INDEX == LARGE {
                ll += v - e;
                lh += v + e;
            } else {
                sl += v - e;
                sh += v + e;
            }
            if cell {
                shares.push((v, e));
            } else if sh - sl > FOUR_PI {
                break;
            }
        }
        ((sl, sh), (ll, lh), shares)
    }

    /// A cell voxel by voxel. Each voxel starts from the far fields at its centre and the kept nodes' shares
    /// over the cell's ball (`shares`, parallel to `keep`), then replaces those shares by their values at the
    /// voxel, the widest first, until its interval is labelled: near a cap a few triangles decide, and the
    /// far part of the list is never evaluated twice. A voxel still unlabelled with every kept node at its
    /// centre refines them (`refine_from`) unless the far fields' own error already straddles a
    /// half-integer; what is left goes to the direct evaluation.
    #[allow(clippy::too_many_arguments)]
    fn cell_voxels(
        &self,
        lo: [u32; 3],
        hi: [u32; 3],
        local: &[Local; 2],
        keep: &[u32],
        shares: &[(f64, f64)],
        large_model: Option<LargeLinear>,
        found: &mut Labels,
    ) {
        let (frame, nu) = (self.frame, self.nu);
        // The kept nodes a voxel starts from, the widest shares first, with their sum over the ball: every
        // one, or (with the large caps' linear model, which stands for the large caps' far field and kept
        // nodes) the small caps' and ribbons' alone.
        let list = |small_only: bool| {
            let mut order: Vec<u32> = (0..keep.len() as u32)
                .filter(|&j| !small_only || keep[j as usize] & !INDEX != LARGE)
                .collect();
            order.sort_unstable_by(|&a, &b| shares[b as usize].1.total_cmp(&shares[a as usize].1));
            let sum = order.iter().fold((0.0, 0.0), |(v, e), &j| {
                let (sv, se) = shares[j as usize];
                (v + sv, e + se)
            });
            (order, sum)
        };
        // The whole list only for the voxels the model leaves open (none, in the middle of a wide cap).
        let all = std::cell::OnceCell::new();
        let small = large_model.map(|_| list(true));
        // A voxel from the far fields `(far, far_err)` and the kept nodes `order`.
        let at_voxel = |q: [f64; 3],
                        (far, far_err): (f64, f64),
                        (order, (ball_v, ball_e)): &(Vec<u32>, (f64, f64))|
         -> Option<i32> {
            let (mut v, mut e) = (far + ball_v, far_err + ball_e);
            let mut answer = label(v - e, v + e);
            for &j in order {
                if answer.is_some() {
                    break;
                }
                let (sv, se) = shares[j as usize];
                let (pv, pe) = self.share_at_voxel(keep[j as usize], q);
                if pe < se {
                    v += pv - sv;
                    e += pe - se;
                    answer = label(v - e, v + e);
                }
            }
            if answer.is_none() && label(v - far_err, v + far_err).is_some() {
                // Refine the kept nodes at this voxel on top of the far fields.
                answer = SCRATCH.with(|s| {
                    refine_from(
                        &[&self.x.caps, &self.x.large, &self.x.ribbons],
                        q,
                        nu,
                        (far, far_err),
                        order
                            .iter()
                            .map(|&j| keep[j as usize])
                            .map(|t| (t >> TREE_SHIFT, t & INDEX)),
                        label,
                        &mut s.borrow_mut().caps,
                    )
                });
            }
            answer
        };
        for z in lo[2]..hi[2] {
            for y in lo[1]..hi[1] {
                for xx in lo[0]..hi[0] {
                    let id = linear(frame, [xx, y, z]);
                    if self.zone.binary_search(&id).is_ok() {
                        continue;
                    }
                    found.voxels_evaluated += 1;
                    let q = centre(frame, [xx, y, z]);
                    let small_far = local[0].value_at(q);
                    // The model first; where its error leaves the voxel open, the large caps' own far field
                    // and kept nodes, evaluated at the voxel.
                    let answer = match (&large_model, &small) {
                        (Some(m), Some(list)) => {
                            at_voxel(q, (small_far + m.value_at(q), local[0].err + m.err), list)
                        }
                        _ => None,
                    }
                    .or_else(|| {
                        let far = (
                            small_far + local[1].value_at(q),
                            local[0].err + local[1].err,
                        );
                        at_voxel(q, far, all.get_or_init(|| list(false)))
                    });
                    match answer {
                        Some(0) => {}
                        Some(k) => found.voxels.push(([xx, y, z], k)),
                        None => found.undecided.push(id),
                    }
                }
            }
        }
    }

    /// A kept node's share at the voxel centre `q`: its expansion, or its leaf triangles exactly (the thin
    /// ones, and any whose bound is below [`TRI_EPS`], by their bound).
    fn share_at_voxel(&self, tag: u32, q: [f64; 3]) -> (f64, f64) {
        let tree = self.tree_of(tag);
        let i = tag & INDEX;
        let node = &tree.nodes[i as usize];
        if !node.is_leaf() {
            return tree.share_at(i, q, self.nu);
        }
        let (mut v, mut e) = (0.0, 0.0);
        for t in &tree.triangles[node.first as usize..(node.first + node.count) as usize] {
            let b = t.bound(q, self.nu);
            if b <= TRI_EPS {
                e += b;
            } else {
                let (w, we) = t.solid_angle(q);
                v += w;
                e += we;
            }
        }
        (v, e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::voxel::gwn::{local_triangles, FractionalField, Proxy};
    use crate::voxel::mesh::TriMesh;

    /// The fractional term of a sphere with a ring of triangles removed, in a 32³ grid round it.
    fn holed_sphere() -> (GridFrame, Fractional) {
        let mut s = TriMesh::sphere([0.0; 3], 1.0, 12, 16, false);
        let n = s.triangles.len();
        s.triangles.drain(n / 2..n / 2 + 16);
        let frame = GridFrame::from_points(&s.positions, 32).unwrap();
        let proxy = Proxy::new(&s, 0.0).unwrap();
        let x = proxy.fractional(&s, frame.origin);
        assert!(local_triangles(&s, frame.origin).len() == s.triangles.len());
        let frac = Fractional {
            caps: Tree::build_with(x.iter().copied(), CAP_LEAF),
            ..Fractional::default()
        };
        (frame, frac)
    }

    #[test]
    fn labelling_stops_at_the_deadline_and_at_the_budget_with_the_callers_errors() {
        let (frame, x) = holed_sphere();
        let expired = AtomicBool::new(true);
        let limits = Limits {
            deadline: None,
            seconds: 1.5,
            max_listed: u64::MAX,
            expired: &expired,
        };
        let e = classify(&frame, &x, 1e-3, &[], &limits).unwrap_err();
        assert!(
            matches!(e, Error::Timeout { seconds, ref stage } if seconds == 1.5 && stage.contains("labelling")),
            "{e}"
        );
        let fresh = AtomicBool::new(false);
        let limits = Limits {
            deadline: None,
            seconds: 0.0,
            max_listed: 0,
            expired: &fresh,
        };
        let e = classify(&frame, &x, 1e-3, &[], &limits).unwrap_err();
        assert!(matches!(e, Error::Budget { .. }), "{e}");
        // With room, it labels: a cap's neighbourhood needs voxels one by one.
        let limits = Limits {
            max_listed: u64::MAX,
            ..limits
        };
        let labels = classify(&frame, &x, 1e-3, &[], &limits).unwrap();
        assert!(
            labels.voxels_evaluated > 0 && labels.boxes_evaluated > 8,
            "{labels:?}"
        );
    }

    #[test]
    fn labels_are_the_integers_strictly_between_half_integers() {
        let w = |x: f64| x * FOUR_PI;
        assert_eq!(label(w(-0.2), w(0.3)), Some(0));
        assert_eq!(label(w(0.6), w(1.4)), Some(1));
        assert_eq!(label(w(-1.4), w(-0.6)), Some(-1));
        assert_eq!(label(w(0.2), w(0.6)), None);
        assert_eq!(label(w(0.0), w(0.5)), None);
        assert_eq!(label(f64::NEG_INFINITY, 0.0), None);
    }

    #[test]
    fn the_large_caps_linear_model_holds_over_a_cell() {
        let mut s = TriMesh::sphere([0.0; 3], 1.0, 12, 16, false);
        let n = s.triangles.len();
        s.triangles.drain(n / 2..n / 2 + 16);
        let proxy = Proxy::new(&s, 0.0).unwrap();
        // A tiny length scale: every cap is large.
        let f = FractionalField::build(&s, &proxy, [0.0; 3], 1e-3, u64::MAX).unwrap();
        assert!(!f.fractional.large.is_empty());
        let exact = |q: [f64; 3]| -> f64 {
            f.fractional
                .large
                .triangles
                .iter()
                .map(|t| t.solid_angle(q).0)
                .sum()
        };
        let mut sc = Scratches::default();
        let mut checked = 0;
        for i in 0..200 {
            let c = [
                -1.2 + 0.0123 * i as f64,
                0.3 * ((i * 7) % 11) as f64 / 11.0 - 0.1,
                0.2 * ((i * 5) % 13) as f64 / 13.0,
            ];
            let ball = Ball {
                c,
                r: 0.02,
                nu: 0.0,
            };
            let Some(m) = f.fractional.large_linear(&ball, &mut sc) else {
                continue;
            };
            for d in [[0.01, 0.0, 0.0], [0.0, -0.015, 0.005], [0.0, 0.0, 0.0]] {
                let q = [c[0] + d[0], c[1] + d[1], c[2] + d[2]];
                let e = exact(q);
                assert!(
                    (e - m.value_at(q)).abs() <= m.err,
                    "{c:?} {d:?}: exact {e}, model {} ± {} (g {:?})",
                    m.value_at(q),
                    m.err,
                    m.gradient
                );
                checked += 1;
            }
        }
        assert!(checked > 100, "{checked}");
    }
}
