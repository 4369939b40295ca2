//! A bounding-volume tree over triangles whose nodes carry far-field expansions of their solid angle with
//! rigorous error bounds: the hierarchy that makes the fractional term of the winding number cost
//! O(log) per query instead of O(triangles).
//!
//! Each node holds the ball (centre x̄, radius ρ) that contains its triangles, their total area A, their
//! total *width* W = Σ (altitude on the longest edge), and the moments of its normal-weighted area
//! up to second order about x̄. Three ways to account for a node at a query ball (centre c, radius r), all
//! rigorous (the node's solid angle at every point of the ball lies in the interval):
//! - **bound**: |Ω_N| ≤ min(A/d², πW/d), d a lower bound on the distance from the ball to the triangles.
//!   The first: |n̂·(x−q)|/|x−q|³ ≤ 1/d² per unit area. The second keeps long thin triangles (the ribbons of
//!   a welded soup, `super::cap`) cheap however close they come. Its proof, per triangle of altitude w on
//!   its longest edge (the spine, direction e): the triangle lies in the strip {S(l) + s·u : 0 ≤ s ≤ w}
//!   (u ⊥ e in its plane), so cut it into the segments of the lines s = const, area dl·ds. On one such
//!   line let h be q's distance to it; every point x of the segment has |q − x| ≥ d (d at most the
//!   distance to the triangle), so ∫ dl/|q − x|² ≤ ∫_{h² + l² ≥ d²} dl/(h² + l²), which is ≤ π/h ≤ π/d
//!   when h ≥ d, and (2/h)·asin(h/d) ≤ π/d when h < d (asin u ≤ πu/2 on [0, 1], asin being convex).
//!   Integrating over s ∈ [0, w]: |Ω| ≤ ∫ dA/|q − x|² ≤ πw/d, and a node's triangles sum to πW/d. (This
//!   replaced the coarser 4W/d of |q − x| ≥ max(d, |l − l₀|): a soup's boxes near its ribbons settle
//!   higher up; the unwelded bunny soup at 256³: 106,568 → 77,144 boxes, labelling 240 → 185 ms, the same
//!   grid; it also implies the πw/s that single triangles had, s their spine distance less w, since s
//!   never exceeds the distance to the triangle.)
//!   Each triangle takes the least of A/d² and πw/d, d = max(s, ν) (ν the caller's guaranteed distance; s
//!   its spine distance less w, which never exceeds its distance: it lies within w of its spine).
//! - **expansion**: the order-2 Taylor expansion of the double-layer kernel about x̄ (Barnes & Jacobson's
//!   dipole, quadrupole and octupole terms), evaluated at c. The kernel is −n̂·∇_δ of 1/|u − δ| (u = q − x̄,
//!   δ = x − x̄, |δ| ≤ ρ, |u| = D), whose degree-n Taylor term is Dⁿφ(u)[δ…δ]/n! up to sign (φ = 1/|u|,
//!   ‖Dⁿφ‖ = n!/Dⁿ⁺¹); the δ-gradient of that term is at most n·|δ|ⁿ⁻¹/Dⁿ⁺¹, so the truncation error is
//!   E ≤ Σ_{n≥4} n·Iₙ₋₁/Dⁿ⁺¹ with Iₖ = ∫|δ|ᵏ dA. With I₃ ≤ √(I₂·I₄) (Cauchy–Schwarz) and Iₖ ≤ ρᵏ⁻⁴·I₄
//!   beyond, E ≤ 4·I₃/D⁵ + (I₄/ρ⁴)/D² · [4t⁴/(1−t) + t⁴/(1−t)²] (t = ρ/D), where the worst case Iₖ = A·ρᵏ
//!   gives the classical A/D² · [4t³/(1−t) + t⁴/(1−t)²]. Nodes keep [`Node::tail3`] ≥ I₃ and
//!   [`Node::tail4`] ≥ I₄/ρ⁴, at first A·ρ³ and A, tightened by [`Tree::tighten_tails`] from I₂ in closed
//!   form and I₄ by an exact degree-4 rule: 0.2–0.55 of the worst case on caps, which is the factor the
//!   truncations that add up over thousands of caps shrink by (the direct voxels of a third of the bunny at
//!   256³: 1.98 → 0.75 s, 36,155 → 22,522 voxels; 300 open shells 3.1 → 1.3 s; the same grids). The
//!   q-gradient's tail is at most 20·I₃/D⁶ + (I₄/ρ⁴)/D³ · Σ_{n≥5} n(n+1) tⁿ⁻¹. Over the ball, the value
//!   moves by at most r·2A/g³ (‖∇_q‖ of the kernel ≤ 2/|x−q|³), g = D − r − ρ. What a box passes to its
//!   children ([`Tree::local_share`]) is the expansion's value, q-gradient and q-Hessian at c (the Hessian's
//!   truncation 120·I₃/D⁷ + (I₄/ρ⁴)/D⁴ · Σ_{n≥5} n(n+1)(n+2) tⁿ⁻¹), a quadratic that departs from the
//!   exact share by at most the three truncations (times 1, r, ½r²) plus the Taylor remainder r³/6 · 24A/g⁵ (‖D⁴φ‖ = 24/d⁵): a
//!   factor (4/3)·r/g below the linear model's ½r²·6A/g⁴, which is what a cell used to inherit from every
//!   box above it. Rounding adds 1e-12·A/(D−ρ)².
//! - **open**: the children, or at a leaf the triangles themselves (the caller sums them exactly, or bounds
//!   each one at each query point).
//!
//! Invariants: triangles are reordered so each leaf owns a contiguous range ([`Tree::triangles`]); a
//! node's children are `first` and `first + 1`; moments are translated up the tree exactly (no second
//! pass over the triangles), radii are the smaller of the children's spheres grown and the half-diagonal of
//! the node's box. The build is O(n log n) and the tree O(n) memory ([`Tree::bytes`]): median splits over
//! compact items (a triangle's box, centroid and index, not the whole [`TreeTriangle`]), halves of more than
//! `PARALLEL_BUILD` triangles built on other threads into node ranges fixed in advance (`node_count`), so
//! the tree — node order included — is the same whatever the number of threads. A single triangle's share
//! over a ball takes its exact distance to the ball (its bounding ball's gap, beside a large cap triangle,
//! would be near zero and the variation bound cubed).
use super::kernel::{norm, segment_distance2, solid_angle_bounded, triangle_distance};
use crate::voxel::surface::{cross, dot, sub};
use rayon::prelude::*;

/// Triangles per leaf at most, by default (thin ribbons; caps use smaller leaves, whose balls stay the
/// size of one cap triangle however sparse the caps are).
pub const LEAF: usize = 8;

/// A triangle of the tree, with what its bounds need.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeTriangle {
    pub a: [f64; 3],
    pub b: [f64; 3],
    pub c: [f64; 3],
    pub area: f64,
    /// Altitude on the longest edge: the triangle lies within this distance of that edge.
    pub width: f64,
    /// The longest edge: its first corner (0: a→b, 1: b→c, 2: c→a).
    pub spine: u8,
    /// A ball holding the triangle: centre (the centroid) and radius.
    pub centre: [f64; 3],
    pub radius: f64,
}

impl TreeTriangle {
    /// The triangle (a, b, c) with its area, width and spine.
    pub fn new([a, b, c]: [[f64; 3]; 3]) -> TreeTriangle {
        let n = cross(sub(b, a), sub(c, a));
        let area = 0.5 * norm(n);
        let edges = [(a, b), (b, c), (c, a)];
        let (mut spine, mut longest) = (0u8, 0.0f64);
        for (k, e) in edges.iter().enumerate() {
            let l = norm(sub(e.1, e.0));
            if l > longest {
                longest = l;
                spine = k as u8;
            }
        }
        // A hair more than the rounded values keeps the bounds bounds.
        let width = if longest > 0.0 {
            2.0 * area / longest * (1.0 + 1e-12)
        } else {
            0.0
        };
        let centre: [f64; 3] = std::array::from_fn(|k| (a[k] + b[k] + c[k]) / 3.0);
        let radius = [a, b, c]
            .iter()
            .map(|&v| norm(sub(v, centre)))
            .fold(0.0f64, f64::max)
            * (1.0 + 1e-12);
        TreeTriangle {
            a,
            b,
            c,
            area: area * (1.0 + 1e-12),
            width,
            spine,
            centre,
            radius,
        }
    }

    /// The distance from `q` to the longest edge.
    #[inline]
    fn spine_distance(&self, q: [f64; 3]) -> f64 {
        let (p, r) = match self.spine {
            0 => (self.a, self.b),
            1 => (self.b, self.c),
            _ => (self.c, self.a),
        };
        segment_distance2(q, p, r).sqrt()
    }

    /// The solid angle at `q` and its rounding bound.
    #[inline]
    pub fn solid_angle(&self, q: [f64; 3]) -> (f64, f64) {
        solid_angle_bounded(q, self.a, self.b, self.c)
    }

    /// The solid angle over every point of `ball` as (value at the centre, error): the rounding plus the
    /// variation r·2A/g³ (g the gap between the ball and the triangle), or ± the bound when that is
    /// narrower (or the ball meets the triangle).
    #[inline]
    pub fn share_over(&self, ball: &Ball) -> (f64, f64) {
        let bound = self.bound_over(ball);
        let variation = |gap: f64| 2.0 * self.area * ball.r / (gap * gap * gap);
        // The gap to the triangle's ball first; where that leaves a wide share, the gap to the triangle
        // itself (beside a large triangle its ball's gap is far smaller, and the variation bound goes as its
        // cube), less its rounding: a few ulps of the coordinates' scale.
        let mut gap = (norm(sub(ball.c, self.centre)) - self.radius - ball.r) * (1.0 - 1e-12);
        if gap <= 0.0 || variation(gap) > WIDE_SHARE.min(bound) {
            let scale = norm(ball.c) + norm(self.centre) + self.radius;
            gap = gap.max(
                (triangle_distance(ball.c, self.a, self.b, self.c) - ball.r - 1e-12 * scale)
                    * (1.0 - 1e-9),
            );
        }
        if gap > 0.0 {
            let (v, e) = self.solid_angle(ball.c);
            let e = e + variation(gap);
            if e < bound {
                return (v, e);
            }
        }
        (0.0, bound)
    }

    /// A bound on |Ω| at every point of `ball` (each at least `ball.nu` from the triangle).
    #[inline]
    pub fn bound_over(&self, ball: &Ball) -> f64 {
        self.width_bound(self.spine_distance(ball.c) - self.width - ball.r, ball.nu)
    }

    /// min(A/d², πw/d) with d = max(s, ν), s the spine distance less the width: a lower bound on the
    /// distance to the triangle, which lies within `width` of its spine (the module docs prove both).
    #[inline]
    fn width_bound(&self, s: f64, nu: f64) -> f64 {
        let d = s.max(nu);
        if d <= 0.0 {
            return f64::INFINITY;
        }
        let d = d * (1.0 - 1e-12);
        (self.area / (d * d)).min(std::f64::consts::PI * self.width / d)
    }

    /// A bound on |Ω| at `q` for a query point at least `nu` from the triangle: min(A/d², πw/d), s the
    /// distance to the spine less the width (the triangle lies within `width` of its spine), d = max(s, ν).
    #[inline]
    pub fn bound(&self, q: [f64; 3], nu: f64) -> f64 {
        self.width_bound(self.spine_distance(q) - self.width, nu)
    }
}

/// A triangle's share over a ball wider than this (steradians) is worth its exact distance to the ball.
const WIDE_SHARE: f64 = 1e-3;

/// A node of the tree. All zeros is [`Node::default`]. What a traversal reads at every node it meets (its
/// ball, area, width and children) comes first, in its first 56 bytes (`repr(C)`: left to the compiler, the
/// children's indices went to the end, a second cache line per node). Not aligned to 64 bytes: that measured
/// about the same and its 8 more bytes a node put the million-gon's trees past the default memory budget.
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Zeroable)]
#[repr(C)]
pub struct Node {
    pub centre: [f64; 3],
    pub radius: f64,
    /// Σ area of the triangles below.
    pub area: f64,
    /// Σ width (altitude on the longest edge) of the triangles below.
    pub width: f64,
    /// Leaf: first triangle; inner node: first child (the second is `first + 1`).
    pub first: u32,
    /// Leaf: triangle count (≥ 1); inner node: 0.
    pub count: u32,
    /// Σ N (vector areas).
    pub m0: [f64; 3],
    /// Σ N_a ∫(x − x̄)_b dA/A, row-major (index 3a + b).
    pub m1: [f64; 9],
    /// Σ N_a ∫(x − x̄)_b (x − x̄)_c dA/A, index 6a + (bc in xx, xy, xz, yy, yz, zz).
    pub m2: [f64; 18],
    /// An upper bound on ∫|x − x̄|³ dA over the node's triangles (A·ρ³ until [`Tree::tighten_tails`]):
    /// the degree-4 term of the expansions' truncation bounds.
    pub tail3: f64,
    /// An upper bound on ∫|x − x̄|⁴ dA / ρ⁴ (A until [`Tree::tighten_tails`]): the terms of degree 5 and
    /// more.
    pub tail4: f64,
}

impl Node {
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// Index into the symmetric pair (b, c) of [`Node::m2`].
const SYM: [[usize; 3]; 3] = [[0, 1, 2], [1, 3, 4], [2, 4, 5]];

/// The tree.
#[derive(Clone, Debug, Default)]
pub struct Tree {
    pub nodes: Vec<Node>,
    pub triangles: Vec<TreeTriangle>,
}

/// How a query accounts for nodes (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Accept {
    /// A node is expanded only when (ρ + r) ≤ θ·D.
    pub theta: f64,
    /// A node whose bound is at most this (steradians) is taken as ± the bound without opening it.
    pub eps: f64,
}

/// How a cell splits the tree: aggregated far field, per-voxel middle nodes, near triangles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CellAccept {
    /// Aggregated over the cell when (ρ + r) ≤ θ·D and the ball's radius is at most `spread`·g (so the
    /// variation term r·2A/g³ stays a small part of the node's A/g²).
    pub theta: f64,
    pub spread: f64,
    /// Else evaluated at each voxel when ρ ≤ `point_theta`·(D − r) (every voxel sees it at t ≤ that).
    pub point_theta: f64,
    /// Bound-only acceptance, as [`Accept::eps`].
    pub eps: f64,
}

/// A query ball: every point of interest lies within `r` of `c`, and at least `nu` from every triangle of
/// the tree (0 when nothing is known).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ball {
    pub c: [f64; 3],
    pub r: f64,
    pub nu: f64,
}

/// A node's share of a point's interval during [`Tree::adaptive`].
#[derive(Clone, Copy, Debug)]
struct Share {
    tree: u32,
    node: u32,
    value: f64,
    err: f64,
}

/// The per-thread scratch of the queries.
#[derive(Default)]
pub struct Scratch {
    stack: Vec<u32>,
    shares: Vec<Share>,
    /// Triangles left to the caller (indices into [`Tree::triangles`]).
    pub near: Vec<u32>,
    /// Nodes left to the caller's points ([`Tree::cell`]).
    pub mid: Vec<u32>,
    /// The most work (shares evaluated, six per share opened) [`adaptive`] may do before it gives up and
    /// answers `None`, so that a caller with a cheaper exact answer (the plain sum over a small mesh) takes
    /// it instead; 0: no limit.
    pub work_limit: u64,
}

impl Tree {
    /// The tree of `triangles` (local f64 corners), [`LEAF`] a leaf.
    pub fn build(triangles: &[[[f64; 3]; 3]]) -> Tree {
        Tree::build_slice(triangles, LEAF)
    }

    /// The tree of `triangles` with at most `leaf` triangles a leaf, its truncation bounds tightened
    /// ([`Tree::tighten_tails`]): what the caps' trees, whose expansions are used, are built with.
    pub fn build_with(triangles: impl IntoIterator<Item = [[f64; 3]; 3]>, leaf: usize) -> Tree {
        let corners: Vec<[[f64; 3]; 3]> = triangles.into_iter().collect();
        let mut tree = Tree::build_slice(&corners, leaf);
        tree.tighten_tails();
        tree
    }

    /// Replaces every node's tail moments A·ρ³ and A by ∫|δ|³ ≤ √(∫|δ|²·∫|δ|⁴) and ∫|δ|⁴/ρ⁴ (Cauchy–Schwarz;
    /// δ = x − x̄), summed over the node's triangles: ∫|δ|² in closed form, ∫|δ|⁴ by a degree-4 rule
    /// (exact for the quartic, positive weights), each raised by 1e-9 for rounding and never above the
    /// old bounds. Measured on a soup (the tests): a leaf of two triangles about 0.54·Aρ³, the root
    /// 0.21·Aρ³ (the truncations are per-node worst cases that add up without cancelling over thousands of
    /// caps, `super::direct`). Cost O(n log n): each triangle once per level, the nodes in parallel.
    pub fn tighten_tails(&mut self) {
        let n = self.nodes.len();
        // Each node's triangle range: children follow their parent, leaves own theirs.
        let mut range = vec![(0u32, 0u32); n];
        for i in (0..n).rev() {
            let node = &self.nodes[i];
            range[i] = if node.is_leaf() {
                (node.first, node.first + node.count)
            } else {
                (
                    range[node.first as usize].0,
                    range[node.first as usize + 1].1,
                )
            };
        }
        let triangles = &self.triangles;
        self.nodes
            .par_iter_mut()
            .zip(range.par_iter())
            .for_each(|(node, &(s, e))| {
                let (mut mu2, mut mu4) = (0.0f64, 0.0f64);
                for t in &triangles[s as usize..e as usize] {
                    let (m2, m4) = absolute_moments(t, node.centre);
                    mu2 += m2;
                    mu4 += m4;
                }
                let slack = 1.0 + 1e-9;
                let rho = node.radius;
                node.tail3 = ((mu2 * mu4).sqrt() * slack).min(node.area * rho.powi(3));
                let tail4 = mu4 * slack / rho.powi(4);
                if tail4.is_finite() {
                    node.tail4 = tail4.min(node.area);
                }
            });
    }

    /// [`Tree::build_with`] on a slice, without copying it (a soup's ribbons are hundreds of thousands).
    pub fn build_slice(corners: &[[[f64; 3]; 3]], leaf: usize) -> Tree {
        if corners.is_empty() {
            return Tree::default();
        }
        let mut items: Vec<Item> = corners
            .par_iter()
            .enumerate()
            .map(|(i, t)| Item::of(i, t))
            .collect();
        let leaf = leaf.max(1);
        // Zeroed (Node::default()) by the allocator: the pages are first touched by the threads that build
        // the nodes, not filled one by one here (a soup's 87,000 ribbon nodes: 22 ms on one thread).
        let mut nodes: Vec<Node> = bytemuck::zeroed_vec(node_count(items.len(), leaf));
        let (root, rest) = nodes.split_first_mut().expect("one node at least");
        // The triangles in leaf order, each made once, by the leaf that holds it.
        let mut tris: Vec<TreeTriangle> = Vec::with_capacity(items.len());
        build_into(
            corners,
            &mut items,
            &mut tris.spare_capacity_mut()[..corners.len()],
            0,
            root,
            rest,
            1,
            leaf,
        );
        // SAFETY: the leaves partition 0..len and each wrote every slot of its range (`build_into`).
        unsafe { tris.set_len(corners.len()) };
        Tree {
            nodes,
            triangles: tris,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Bytes the tree holds (what the memory budget counts).
    pub fn bytes(&self) -> u64 {
        (self.nodes.len() * std::mem::size_of::<Node>()
            + self.triangles.len() * std::mem::size_of::<TreeTriangle>()) as u64
    }

    /// Bytes a tree of `n` triangles with leaves of at most `leaf` holds at most (median splits leave at
    /// least ⌈leaf/2⌉ in a leaf, so at most 2n/⌈leaf/2⌉ nodes).
    pub fn bytes_for(n: usize, leaf: usize) -> u64 {
        let half = leaf.div_ceil(2).max(1) as u64;
        (n as u64) * (std::mem::size_of::<TreeTriangle>() as u64)
            + (2 * (n as u64).div_ceil(half) + 1) * std::mem::size_of::<Node>() as u64
    }

    /// The bound-only share of `node` at a ball `gap` away (at least `nu`): ± min(A/d², πW/d).
    #[inline]
    pub fn node_bound(node: &Node, gap: f64, nu: f64) -> f64 {
        let dlo = gap.max(nu) * (1.0 - 1e-12);
        if dlo > 0.0 {
            (node.area / (dlo * dlo)).min(std::f64::consts::PI * node.width / dlo)
        } else {
            f64::INFINITY
        }
    }

    /// An interval [lo, hi] (steradians) holding the solid angle of every triangle of the tree at every point
    /// of `ball` (leaves not accepted are bounded). `None` as soon as it is wider than `max_width`.
    pub fn interval(
        &self,
        ball: &Ball,
        accept: &Accept,
        max_width: f64,
        scratch: &mut Scratch,
    ) -> Option<(f64, f64)> {
        let (mut lo, mut hi) = (0.0f64, 0.0f64);
        if self.nodes.is_empty() {
            return Some((0.0, 0.0));
        }
        let stack = &mut scratch.stack;
        stack.clear();
        stack.push(0);
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            let d = norm(sub(ball.c, node.centre));
            let gap = d - ball.r - node.radius;
            let bound = Self::node_bound(node, gap, ball.nu);
            if bound <= accept.eps {
                lo -= bound;
                hi += bound;
                continue;
            }
            if gap > 0.0 && node.radius + ball.r <= accept.theta * d {
                let (v, e) = expansion_or_bound(node, ball.c, d, ball.r, gap, bound);
                lo += v - e;
                hi += v + e;
            } else if node.is_leaf() {
                lo -= bound;
                hi += bound;
            } else {
                stack.push(node.first);
                stack.push(node.first + 1);
                continue;
            }
            if hi - lo > max_width {
                return None;
            }
        }
        Some((lo, hi))
    }

    /// A cell's split of the tree: the interval of the nodes far from the whole ball, and in
    /// `scratch.mid` the nodes each point of the ball should expand itself ([`Tree::share_at`]), in
    /// `scratch.near` the triangles of the leaves nearer still.
    pub fn cell(&self, ball: &Ball, accept: &CellAccept, scratch: &mut Scratch) -> (f64, f64) {
        let (mut lo, mut hi) = (0.0f64, 0.0f64);
        scratch.near.clear();
        scratch.mid.clear();
        if self.nodes.is_empty() {
            return (0.0, 0.0);
        }
        let stack = &mut scratch.stack;
        stack.clear();
        stack.push(0);
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            let d = norm(sub(ball.c, node.centre));
            let gap = d - ball.r - node.radius;
            let bound = Self::node_bound(node, gap, ball.nu);
            if bound <= accept.eps {
                lo -= bound;
                hi += bound;
                continue;
            }
            if gap > 0.0
                && node.radius + ball.r <= accept.theta * d
                && ball.r <= accept.spread * gap
            {
                let (v, e) = expansion_or_bound(node, ball.c, d, ball.r, gap, bound);
                lo += v - e;
                hi += v + e;
            } else if gap > 0.0 && node.radius <= accept.point_theta * (d - ball.r) {
                scratch.mid.push(i);
            } else if node.is_leaf() {
                scratch.near.extend(node.first..node.first + node.count);
            } else {
                stack.push(node.first);
                stack.push(node.first + 1);
            }
        }
        (lo, hi)
    }

    /// Node `i`'s share of the solid angle at point `q` (at least `nu` from its triangles): its expansion
    /// with the truncation bound, or ± its bound, whichever is narrower: (value, error).
    #[inline]
    pub fn share_at(&self, i: u32, q: [f64; 3], nu: f64) -> (f64, f64) {
        self.share_over(i, &Ball { c: q, r: 0.0, nu })
    }

    /// Node `i`'s share over every point of `ball`: (value, error) as [`Tree::share_at`], the expansion's
    /// error including its variation over the ball.
    #[inline]
    pub fn share_over(&self, i: u32, ball: &Ball) -> (f64, f64) {
        let node = &self.nodes[i as usize];
        let d = norm(sub(ball.c, node.centre));
        let gap = d - ball.r - node.radius;
        let bound = Self::node_bound(node, gap, ball.nu);
        if gap > 0.0 && node.radius < 0.95 * d {
            return expansion_or_bound(node, ball.c, d, ball.r, gap, bound);
        }
        (0.0, bound)
    }

    /// An interval [lo, hi] (steradians) for the solid angle of the whole tree at the point `c` alone, or
    /// `None` when a triangle comes within `clear` of `c` (the caller's ball would meet the surface, across
    /// which the solid angle jumps by 4π). Nodes are expanded at `c` (truncation error only), bounded, or
    /// opened; leaves near `c` are summed exactly.
    pub fn interval_at(
        &self,
        c: [f64; 3],
        clear: f64,
        accept: &Accept,
        scratch: &mut Scratch,
    ) -> Option<(f64, f64)> {
        let (mut sum, mut err) = (0.0f64, 0.0f64);
        if self.nodes.is_empty() {
            return Some((0.0, 0.0));
        }
        let stack = &mut scratch.stack;
        stack.clear();
        stack.push(0);
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            let d = norm(sub(c, node.centre));
            let gap = d - node.radius;
            if gap > clear {
                let bound = Self::node_bound(node, gap, 0.0);
                if bound <= accept.eps {
                    err += bound;
                    continue;
                }
                if node.radius <= accept.theta * d {
                    let (v, e) = expansion_or_bound(node, c, d, 0.0, gap, bound);
                    sum += v;
                    err += e;
                    continue;
                }
            }
            if node.is_leaf() {
                for t in &self.triangles[node.first as usize..(node.first + node.count) as usize] {
                    if gap <= clear && triangle_distance(c, t.a, t.b, t.c) <= clear * (1.0 + 1e-12)
                    {
                        return None;
                    }
                    let (v, e) = t.solid_angle(c);
                    sum += v;
                    err += e;
                }
            } else {
                stack.push(node.first);
                stack.push(node.first + 1);
            }
        }
        err += 64.0 * f64::EPSILON * (sum.abs() + err);
        Some((sum - err, sum + err))
    }

    /// A bound on |Ω| of the whole tree over `ball` from the nodes' and triangles' bounds alone (for thin
    /// triangles, whose solid angle matters only as a bound). Nodes whose bound is at most `eps` are not
    /// opened; with `keep_near`, leaf triangles are left in `scratch.near` instead of bounded.
    pub fn bound_over(&self, ball: &Ball, eps: f64, keep_near: bool, scratch: &mut Scratch) -> f64 {
        let mut sum = 0.0f64;
        scratch.near.clear();
        if self.nodes.is_empty() {
            return 0.0;
        }
        let stack = &mut scratch.stack;
        stack.clear();
        stack.push(0);
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            let gap = norm(sub(ball.c, node.centre)) - ball.r - node.radius;
            let bound = Self::node_bound(node, gap, ball.nu);
            if bound <= eps {
                sum += bound;
            } else if node.is_leaf() {
                if keep_near {
                    scratch.near.extend(node.first..node.first + node.count);
                } else {
                    for t in
                        &self.triangles[node.first as usize..(node.first + node.count) as usize]
                    {
                        sum += t.bound_over(ball);
                    }
                }
            } else {
                stack.push(node.first);
                stack.push(node.first + 1);
            }
        }
        sum
    }
}

/// Decides at point `q` (at least `nu` from every triangle of `trees`): starts from a traversal of each
/// tree with `accept`, then opens the shares with the largest errors (their children, or a leaf's triangles
/// summed exactly) until `decide(lo, hi)` answers for the interval [lo, hi] (steradians) of all the trees
/// together. `None` once everything is exact and still undecided.
pub fn adaptive<T>(
    trees: &[&Tree],
    q: [f64; 3],
    nu: f64,
    accept: &Accept,
    decide: impl FnMut(f64, f64) -> Option<T>,
    scratch: &mut Scratch,
) -> Option<T> {
    let (mut exact, mut exact_err) = (0.0f64, 0.0f64);
    scratch.shares.clear();
    for (k, tree) in trees.iter().enumerate() {
        if tree.nodes.is_empty() {
            continue;
        }
        let stack = &mut scratch.stack;
        stack.clear();
        stack.push(0);
        while let Some(i) = stack.pop() {
            let node = &tree.nodes[i as usize];
            let d = norm(sub(q, node.centre));
            let gap = d - node.radius;
            let bound = Tree::node_bound(node, gap, nu);
            if bound <= accept.eps || (gap > 0.0 && node.radius <= accept.theta * d) {
                let (value, err) = tree.share_at(i, q, nu);
                scratch.shares.push(Share {
                    tree: k as u32,
                    node: i,
                    value,
                    err,
                });
            } else if node.is_leaf() {
                exact_leaf(tree, node, q, &mut exact, &mut exact_err);
            } else {
                stack.push(node.first);
                stack.push(node.first + 1);
            }
        }
    }
    refine(trees, q, nu, (exact, exact_err), decide, scratch)
}

/// As [`adaptive`], from a known part `(value, error)` and the nodes `start` ((tree, node) pairs) that make
/// up the rest.
pub fn refine_from<T>(
    trees: &[&Tree],
    q: [f64; 3],
    nu: f64,
    base: (f64, f64),
    start: impl IntoIterator<Item = (u32, u32)>,
    decide: impl FnMut(f64, f64) -> Option<T>,
    scratch: &mut Scratch,
) -> Option<T> {
    scratch.shares.clear();
    for (tree, node) in start {
        let (value, err) = trees[tree as usize].share_at(node, q, nu);
        scratch.shares.push(Share {
            tree,
            node,
            value,
            err,
        });
    }
    refine(trees, q, nu, base, decide, scratch)
}

fn exact_leaf(tree: &Tree, node: &Node, q: [f64; 3], exact: &mut f64, exact_err: &mut f64) {
    for t in &tree.triangles[node.first as usize..(node.first + node.count) as usize] {
        let (w, e) = t.solid_angle(q);
        *exact += w;
        *exact_err += e;
    }
}

/// The refinement loop of [`adaptive`] over `scratch.shares`, on top of `(value, error)`.
fn refine<T>(
    trees: &[&Tree],
    q: [f64; 3],
    nu: f64,
    (base, base_err): (f64, f64),
    mut decide: impl FnMut(f64, f64) -> Option<T>,
    scratch: &mut Scratch,
) -> Option<T> {
    let scratch_limit = scratch.work_limit;
    let shares = &mut scratch.shares;
    let (mut sum, mut err, mut mag) = (base, base_err, base.abs());
    for s in shares.iter() {
        sum += s.value;
        err += s.err;
        mag += s.value.abs();
    }
    let mut operations = shares.len() as f64 + 2.0;
    loop {
        // The rounding of the running sums (each operation adds at most ε of the magnitudes so far).
        let round = 4.0 * operations * f64::EPSILON * (mag + err);
        if let Some(answer) = decide(sum - err - round, sum + err + round) {
            return Some(answer);
        }
        if shares.is_empty() || (scratch_limit > 0 && operations > scratch_limit as f64) {
            return None;
        }
        // Open the worst quarter (at least 8) of the shares.
        let k = (shares.len() / 4).max(8).min(shares.len());
        if k < shares.len() {
            shares.select_nth_unstable_by(k - 1, |a, b| b.err.total_cmp(&a.err));
        }
        for j in 0..k {
            let s = shares[j];
            sum -= s.value;
            err -= s.err;
            let tree = trees[s.tree as usize];
            let node = &tree.nodes[s.node as usize];
            if node.is_leaf() {
                let (mut e, mut ee) = (0.0, 0.0);
                exact_leaf(tree, node, q, &mut e, &mut ee);
                sum += e;
                err += ee;
                mag += e.abs();
            } else {
                for c in [node.first, node.first + 1] {
                    let (value, e) = tree.share_at(c, q, nu);
                    sum += value;
                    err += e;
                    mag += value.abs();
                    shares.push(Share {
                        tree: s.tree,
                        node: c,
                        value,
                        err: e,
                    });
                }
            }
            operations += 6.0;
        }
        shares.drain(..k);
    }
}

/// A node's share over the ball of radius `r` at `c` (`d` from its centre, `gap` clear of it): its
/// expansion with the truncation error when that is narrower than `bound`, else 0 ± `bound`.
#[inline]
fn expansion_or_bound(
    node: &Node,
    c: [f64; 3],
    d: f64,
    r: f64,
    gap: f64,
    bound: f64,
) -> (f64, f64) {
    let (v, e) = expand(node, c, d, r, gap);
    if e < bound {
        (v, e)
    } else {
        (0.0, bound)
    }
}

/// The truncation error of `node`'s order-2 expansion at distance `d` (t = ρ/d < 1):
/// Σ_(n≥4) n·∫|δ|ⁿ⁻¹/dⁿ⁺¹, the degree-4 term from ∫|δ|³ ([`Node::tail3`]), the rest from ∫|δ|⁴·ρⁿ⁻⁵
/// ([`Node::tail4`]) times Σ_(n≥5) n·tⁿ⁻¹ = 4t⁴/(1−t) + t⁴/(1−t)².
#[inline]
fn value_tail(node: &Node, d: f64, t: f64) -> f64 {
    let (one, t4, d2) = (1.0 - t, t * t * t * t, d * d);
    4.0 * node.tail3 / (d2 * d2 * d) + node.tail4 / d2 * (4.0 * t4 / one + t4 / (one * one))
}

/// The order-2 expansion of `node` at `c` (distance `d` from its centre) and its error over the ball of
/// radius `r` round `c` (`gap` = d − r − ρ > 0).
#[inline]
fn expand(node: &Node, c: [f64; 3], d: f64, r: f64, gap: f64) -> (f64, f64) {
    // y = x̄ − c: the kernel is N·y/|y|³ and its derivatives at y.
    let y = sub(node.centre, c);
    let inv = 1.0 / d;
    let inv3 = inv * inv * inv;
    let inv5 = inv3 * inv * inv;
    let inv7 = inv5 * inv * inv;
    let m1 = &node.m1;
    let m2 = &node.m2;
    let t1 = dot(node.m0, y) * inv3;
    // Σ_ab M1_ab (δ_ab/r³ − 3 y_a y_b/r⁵).
    let mut ymy = 0.0;
    for a in 0..3 {
        for b in 0..3 {
            ymy += m1[3 * a + b] * y[a] * y[b];
        }
    }
    let trace = m1[0] + m1[4] + m1[8];
    let t2 = trace * inv3 - 3.0 * ymy * inv5;
    // ½ Σ_abc M2_abc (−3(δ_ab y_c + δ_ac y_b + δ_bc y_a)/r⁵ + 15 y_a y_b y_c/r⁷).
    let (mut lin, mut cubic) = (0.0, 0.0);
    for a in 0..3 {
        let row = &m2[6 * a..6 * a + 6];
        // δ_ab y_c + δ_ac y_b: 2 Σ_c M2_{a a c} y_c; δ_bc y_a: y_a tr(M2_a).
        let mut s = 0.0;
        for c in 0..3 {
            s += row[SYM[a][c]] * y[c];
        }
        let tr = row[0] + row[3] + row[5];
        lin += 2.0 * s + tr * y[a];
        let mut q = 0.0;
        for b in 0..3 {
            for c in 0..3 {
                q += row[SYM[b][c]] * y[b] * y[c];
            }
        }
        cubic += y[a] * q;
    }
    let t3 = 0.5 * (-3.0 * lin * inv5 + 15.0 * cubic * inv7);
    let value = t1 + t2 + t3;
    let truncation = value_tail(node, d, node.radius / d);
    let near = d - node.radius;
    let rounding = 1e-12 * node.area / (near * near);
    let variation = if r > 0.0 {
        2.0 * node.area * r / (gap * gap * gap)
    } else {
        0.0
    };
    (value, (truncation + rounding + variation) * (1.0 + 1e-9))
}

/// The odd inverse powers of d = |y| that the expansion's derivatives take: d⁻², d⁻³, d⁻⁵, d⁻⁷, d⁻⁹.
#[derive(Clone, Copy)]
struct InversePowers {
    inv2: f64,
    inv3: f64,
    inv5: f64,
    inv7: f64,
    inv9: f64,
}

impl InversePowers {
    #[inline]
    fn of(d: f64) -> InversePowers {
        let inv = 1.0 / d;
        let inv2 = inv * inv;
        let inv3 = inv2 * inv;
        let inv5 = inv3 * inv2;
        let inv7 = inv5 * inv2;
        InversePowers {
            inv2,
            inv3,
            inv5,
            inv7,
            inv9: inv7 * inv2,
        }
    }
}

/// The order-2 expansion of `node` at `c` and its q-gradient (`d` = |c − x̄|): what the tests check the
/// Hessian against (the library takes both from [`expand_hess`]).
#[cfg(test)]
fn expand_grad(node: &Node, c: [f64; 3], d: f64) -> (f64, [f64; 3]) {
    expand_grad_at(node, sub(node.centre, c), &InversePowers::of(d))
}

/// [`expand_grad`] from y = x̄ − c and the powers of |y|.
#[inline]
fn expand_grad_at(node: &Node, y: [f64; 3], powers: &InversePowers) -> (f64, [f64; 3]) {
    let InversePowers {
        inv3,
        inv5,
        inv7,
        inv9,
        ..
    } = *powers;
    let (m0, m1, m2) = (&node.m0, &node.m1, &node.m2);
    // t1 = M0·y/r³.
    let m0y = dot(*m0, y);
    let t1 = m0y * inv3;
    let mut g: [f64; 3] = std::array::from_fn(|k| m0[k] * inv3 - 3.0 * m0y * y[k] * inv5);
    // t2 = tr(M1)/r³ − 3 yᵀM1y/r⁵.
    let m1y: [f64; 3] =
        std::array::from_fn(|a| m1[3 * a] * y[0] + m1[3 * a + 1] * y[1] + m1[3 * a + 2] * y[2]);
    let m1ty: [f64; 3] =
        std::array::from_fn(|b| m1[b] * y[0] + m1[3 + b] * y[1] + m1[6 + b] * y[2]);
    let ymy = dot(y, m1y);
    let tr1 = m1[0] + m1[4] + m1[8];
    let t2 = tr1 * inv3 - 3.0 * ymy * inv5;
    for k in 0..3 {
        g[k] +=
            -3.0 * tr1 * y[k] * inv5 - 3.0 * (m1y[k] + m1ty[k]) * inv5 + 15.0 * ymy * y[k] * inv7;
    }
    // t3 = ½(−3 u·y/r⁵ + 15 C/r⁷), u_c = 2 Σ_a M2_a,ac + tr M2_c, C = Σ_a y_a yᵀM2_a y.
    let mut u = [0.0f64; 3];
    let mut cubic = 0.0;
    let mut grad_c = [0.0f64; 3];
    for a in 0..3 {
        let row = &m2[6 * a..6 * a + 6];
        for (cc, uc) in u.iter_mut().enumerate() {
            *uc += 2.0 * row[SYM[a][cc]];
        }
        u[a] += row[0] + row[3] + row[5];
        let my: [f64; 3] = std::array::from_fn(|b| {
            row[SYM[b][0]] * y[0] + row[SYM[b][1]] * y[1] + row[SYM[b][2]] * y[2]
        });
        let q = dot(y, my);
        cubic += y[a] * q;
        grad_c[a] += q;
        for (b, gc) in grad_c.iter_mut().enumerate() {
            *gc += 2.0 * y[a] * my[b];
        }
    }
    let lin = dot(u, y);
    let t3 = 0.5 * (-3.0 * lin * inv5 + 15.0 * cubic * inv7);
    for k in 0..3 {
        g[k] += 0.5
            * (-3.0 * u[k] * inv5 + 15.0 * lin * y[k] * inv7 + 15.0 * grad_c[k] * inv7
                - 105.0 * cubic * y[k] * inv9);
    }
    // ∇_q = −∇_y.
    (t1 + t2 + t3, g.map(|x| -x))
}

/// Adds to `h` (the y-Hessian, packed as [`PACKED`]) that of P(y)·|y|⁻ⁿ, given P, ∇P and ∇²P (packed
/// alike), with `inv2` = |y|⁻² and `rn` = |y|⁻ⁿ.
#[inline]
fn add_hessian_of_power(
    h: &mut [f64; 6],
    y: [f64; 3],
    (p, dp, ddp): (f64, [f64; 3], [f64; 6]),
    n: f64,
    inv2: f64,
    rn: f64,
) {
    // ∇|y|⁻ⁿ = −n|y|⁻ⁿ⁻² y, ∇²|y|⁻ⁿ = −n|y|⁻ⁿ⁻² I + n(n+2)|y|⁻ⁿ⁻⁴ y yᵀ.
    let (a, b) = (-n * rn * inv2, n * (n + 2.0) * rn * inv2 * inv2);
    for (k, &(i, j)) in PACKED.iter().enumerate() {
        let delta = if i == j { 1.0 } else { 0.0 };
        h[k] += ddp[k] * rn + a * (dp[i] * y[j] + dp[j] * y[i]) + p * (a * delta + b * y[i] * y[j]);
    }
}

/// The (i, j) pairs of a packed symmetric 3×3 matrix: xx, xy, xz, yy, yz, zz.
pub const PACKED: [(usize, usize); 6] = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];

/// The order-2 expansion of `node` at `c` with its q-gradient and q-Hessian (packed as [`PACKED`]): the
/// terms t1 = M0·y/r³, t2 = tr M1/r³ − 3yᵀM1y/r⁵ and t3 = ½(−3u·y/r⁵ + 15C(y)/r⁷) of [`expand`], each a
/// polynomial P(y) times r⁻ⁿ, differentiated by [`add_hessian_of_power`] (y = x̄ − c, so ∇_q = −∇_y and
/// ∇²_q = ∇²_y).
fn expand_hess(node: &Node, c: [f64; 3], d: f64) -> (f64, [f64; 3], [f64; 6]) {
    let y = sub(node.centre, c);
    let powers = InversePowers::of(d);
    let (v, g) = expand_grad_at(node, y, &powers);
    let InversePowers {
        inv2,
        inv3,
        inv5,
        inv7,
        ..
    } = powers;
    let (m0, m1, m2) = (&node.m0, &node.m1, &node.m2);
    let mut h = [0.0f64; 6];
    // t1: P = M0·y.
    add_hessian_of_power(&mut h, y, (dot(*m0, y), *m0, [0.0; 6]), 3.0, inv2, inv3);
    // t2: tr M1 (a constant), then −3yᵀM1y: ∇ = −3(M1 + M1ᵀ)y, ∇² = −3(M1 + M1ᵀ).
    let tr1 = m1[0] + m1[4] + m1[8];
    add_hessian_of_power(&mut h, y, (tr1, [0.0; 3], [0.0; 6]), 3.0, inv2, inv3);
    let sym1 = |i: usize, j: usize| m1[3 * i + j] + m1[3 * j + i];
    let s1y: [f64; 3] = std::array::from_fn(|i| (0..3).map(|j| sym1(i, j) * y[j]).sum());
    let t2b = (
        -1.5 * dot(s1y, y),
        s1y.map(|x| -3.0 * x),
        PACKED.map(|(i, j)| -3.0 * sym1(i, j)),
    );
    add_hessian_of_power(&mut h, y, t2b, 5.0, inv2, inv5);
    // t3: −(3/2)u·y, then (15/2)C(y), C = Σ_a y_a yᵀM2_a y with M2_a symmetric:
    // ∇C_k = yᵀM2_k y + 2Σ_a y_a (M2_a y)_k, ∇²C_kl = 2(M2_k y)_l + 2(M2_l y)_k + 2Σ_a y_a (M2_a)_kl.
    let m2a = |a: usize, b: usize, cc: usize| m2[6 * a + SYM[b][cc]];
    let mut u = [0.0f64; 3];
    for a in 0..3 {
        for (cc, uc) in u.iter_mut().enumerate() {
            *uc += 2.0 * m2a(a, a, cc);
        }
        u[a] += m2[6 * a] + m2[6 * a + 3] + m2[6 * a + 5];
    }
    let t3a = (-1.5 * dot(u, y), u.map(|x| -1.5 * x), [0.0; 6]);
    add_hessian_of_power(&mut h, y, t3a, 5.0, inv2, inv5);
    // (M2_a y)_b for every a, b.
    let my: [[f64; 3]; 3] = std::array::from_fn(|a| {
        std::array::from_fn(|b| (0..3).map(|cc| m2a(a, b, cc) * y[cc]).sum())
    });
    let cubic: f64 = (0..3).map(|a| y[a] * dot(y, my[a])).sum();
    let grad_c: [f64; 3] =
        std::array::from_fn(|k| dot(y, my[k]) + 2.0 * (0..3).map(|a| y[a] * my[a][k]).sum::<f64>());
    let hess_c = PACKED.map(|(k, l)| {
        2.0 * (my[k][l] + my[l][k]) + 2.0 * (0..3).map(|a| y[a] * m2a(a, k, l)).sum::<f64>()
    });
    let t3b = (
        7.5 * cubic,
        grad_c.map(|x| 7.5 * x),
        hess_c.map(|x| 7.5 * x),
    );
    add_hessian_of_power(&mut h, y, t3b, 7.0, inv2, inv7);
    (v, g, h)
}

/// H·δ for a packed symmetric H.
#[inline]
pub fn packed_times(h: &[f64; 6], d: [f64; 3]) -> [f64; 3] {
    [
        h[0] * d[0] + h[1] * d[1] + h[2] * d[2],
        h[1] * d[0] + h[3] * d[1] + h[4] * d[2],
        h[2] * d[0] + h[4] * d[1] + h[5] * d[2],
    ]
}

/// A bound on the spectral norm of a packed symmetric matrix: its Frobenius norm.
#[inline]
pub fn packed_norm(h: &[f64; 6]) -> f64 {
    let diagonal = h[0] * h[0] + h[3] * h[3] + h[5] * h[5];
    (diagonal + 2.0 * (h[1] * h[1] + h[2] * h[2] + h[4] * h[4])).sqrt()
}

impl Tree {
    /// Node `i`'s share of a box's quadratic model at the centre c of `ball` ([`LocalShare`]): its error
    /// bounds, at every point q of the ball, |Ω_N(q) − value − gradient·δ − ½δᵀHδ| (δ = q − c): the
    /// truncations of the value, the gradient and the Hessian at c (times 1, r and ½r²) and the Taylor
    /// remainder r³/6 · 24A/g⁵ (‖D⁴φ‖ = 24/d⁵). `None` unless the node lies outside the ball (g > 0) with
    /// t = ρ/D < 0.9.
    pub fn local_share(&self, i: u32, ball: &Ball) -> Option<LocalShare> {
        self.local_share_below(i, ball, f64::INFINITY)
    }

    /// [`Tree::local_share`], or `None` without evaluating the expansion when its error would not be
    /// below `limit` (the caller then takes the node's bound instead: the expansion is most of the cost).
    pub fn local_share_below(&self, i: u32, ball: &Ball, limit: f64) -> Option<LocalShare> {
        let node = &self.nodes[i as usize];
        let d = norm(sub(ball.c, node.centre));
        let gap = (d - ball.r - node.radius) * (1.0 - 1e-12);
        let t = node.radius / d;
        if gap <= 0.0 || t >= 0.9 {
            return None;
        }
        let one = 1.0 - t;
        let (t4, a) = (t * t * t * t, node.area);
        let (d2, d3) = (d * d, d * d * d);
        let (d4, d5) = (d2 * d2, d2 * d3);
        // The gradient's and the Hessian's tails as [`value_tail`]'s: Σ_(n≥4) n(n+1) and n(n+1)(n+2)
        // times ∫|δ|ⁿ⁻¹/Dⁿ⁺² (⁺³), term by term (all positive).
        let (b3, b4) = (node.tail3, node.tail4);
        let value_tail = value_tail(node, d, t);
        let grad_tail = 20.0 * b3 / (d5 * d)
            + b4 / d3
                * (20.0 * t4 / one + 10.0 * t4 / (one * one) + 2.0 * t4 * t / (one * one * one));
        let hess_tail = 120.0 * b3 / (d5 * d2)
            + b4 / d4
                * (120.0 * t4 / one
                    + 90.0 * t4 / (one * one)
                    + 36.0 * t4 * t / (one * one * one)
                    + 6.0 * t4 * t * t / (one * one * one * one));
        let r = ball.r;
        let remainder = 4.0 * r * r * r * a / (gap * gap * gap * gap * gap);
        let near = d - node.radius;
        let q = r / near;
        let rounding = 1e-12 * a / (near * near) * (1.0 + q + q * q);
        let err = (value_tail + r * grad_tail + 0.5 * r * r * hess_tail + remainder + rounding)
            * (1.0 + 1e-9);
        if err >= limit {
            return None;
        }
        let (value, gradient, hessian) = expand_hess(node, ball.c, d);
        Some(LocalShare {
            value,
            gradient,
            hessian,
            err,
        })
    }
}

/// A node's share of a box's quadratic model ([`Tree::local_share`]).
#[derive(Clone, Copy, Debug)]
pub struct LocalShare {
    pub value: f64,
    pub gradient: [f64; 3],
    /// The q-Hessian, packed as [`PACKED`].
    pub hessian: [f64; 6],
    pub err: f64,
}

/// What the build moves while it splits: a triangle's index, its corners' box and its centroid (a fraction
/// of a [`TreeTriangle`]'s bytes, so the median selections stay cheap on hundreds of thousands of ribbons).
#[derive(Clone, Copy)]
struct Item {
    lo: [f64; 3],
    hi: [f64; 3],
    centroid: [f64; 3],
    index: u32,
}

impl Item {
    fn of(index: usize, corners: &[[f64; 3]; 3]) -> Item {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for &v in corners {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        Item {
            lo,
            hi,
            centroid: std::array::from_fn(|k| {
                (corners[0][k] + corners[1][k] + corners[2][k]) / 3.0
            }),
            index: index as u32,
        }
    }
}

/// Nodes of the tree over `n` triangles with at most `leaf` a leaf (median splits): 2·leaves − 1, in
/// O(log n). Halving ⌊s/2⌋, ⌈s/2⌉ keeps every level's sizes within one of each other, so a level is two
/// (size, count) pairs.
fn node_count(n: usize, leaf: usize) -> usize {
    let (mut level, mut leaves) = (vec![(n, 1usize)], 0usize);
    while !level.is_empty() {
        let mut next: Vec<(usize, usize)> = Vec::with_capacity(2);
        for (size, count) in level {
            if size <= leaf {
                leaves += count;
                continue;
            }
            for half in [size / 2, size - size / 2] {
                match next.iter_mut().find(|(s, _)| *s == half) {
                    Some((_, c)) => *c += count,
                    None => next.push((half, count)),
                }
            }
        }
        level = next;
    }
    2 * leaves - 1
}

/// Items from which a subtree's halves are built in parallel.
const PARALLEL_BUILD: usize = 4096;

/// Builds the subtree over `items` (reordered; they start at `offset` in the whole list, which leaves
/// index; `out`, as long as `items`, receives their triangles in leaf order, every slot written) into `root`
/// and `rest` (its other nodes, which start at index `rest_base`): an inner node's
/// children are `rest[0]` and `rest[1]`, then come the left child's other nodes, then the right child's.
/// Median split of the centroids along the longest axis of their box; the layout does not depend on the
/// number of threads (large halves are built in parallel into their own ranges).
#[allow(clippy::too_many_arguments)]
fn build_into(
    corners: &[[[f64; 3]; 3]],
    items: &mut [Item],
    out: &mut [std::mem::MaybeUninit<TreeTriangle>],
    offset: usize,
    root: &mut Node,
    rest: &mut [Node],
    rest_base: usize,
    leaf: usize,
) {
    let n = items.len();
    let (lo, hi, clo, chi) = bounds(items);
    let centre: [f64; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
    if n <= leaf {
        let mut node = Node {
            centre,
            first: offset as u32,
            count: n as u32,
            ..Node::default()
        };
        let mut radius = 0.0f64;
        for (item, slot) in items.iter().zip(out.iter_mut()) {
            let t = TreeTriangle::new(corners[item.index as usize]);
            for v in [t.a, t.b, t.c] {
                radius = radius.max(norm(sub(v, centre)));
            }
            add_triangle(&mut node, &t);
            slot.write(t);
        }
        node.radius = radius * (1.0 + 1e-12);
        node.tail3 = node.area * node.radius.powi(3);
        node.tail4 = node.area;
        *root = node;
        return;
    }
    let axis = (0..3)
        .max_by(|&a, &b| (chi[a] - clo[a]).total_cmp(&(chi[b] - clo[b])))
        .expect("three axes");
    let mid = n / 2;
    items.select_nth_unstable_by(mid, |p, q| {
        p.centroid[axis]
            .total_cmp(&q.centroid[axis])
            .then(p.index.cmp(&q.index))
    });
    let (left, right) = items.split_at_mut(mid);
    let (out_left, out_right) = out.split_at_mut(mid);
    let (children, below) = rest.split_at_mut(2);
    let (l, r) = children.split_at_mut(1);
    let (left_rest, right_rest) = below.split_at_mut(node_count(mid, leaf) - 1);
    let right_base = rest_base + 2 + left_rest.len();
    let mut build_left = || {
        build_into(
            corners,
            left,
            out_left,
            offset,
            &mut l[0],
            left_rest,
            rest_base + 2,
            leaf,
        )
    };
    let mut build_right = || {
        build_into(
            corners,
            right,
            out_right,
            offset + mid,
            &mut r[0],
            right_rest,
            right_base,
            leaf,
        )
    };
    if n > PARALLEL_BUILD {
        rayon::join(build_left, build_right);
    } else {
        build_left();
        build_right();
    }
    *root = inner_node(centre, 0.5 * norm(sub(hi, lo)), rest_base, &l[0], &r[0]);
}

/// The inner node over children `l` and `r` (stored at `first`, `first + 1`), centred at `centre` (the
/// middle of its triangles' box, `half_diagonal` its half diagonal).
fn inner_node(centre: [f64; 3], half_diagonal: f64, first: usize, l: &Node, r: &Node) -> Node {
    let mut node = Node {
        centre,
        first: first as u32,
        count: 0,
        area: l.area + r.area,
        width: l.width + r.width,
        ..Node::default()
    };
    let grown = [l, r]
        .iter()
        .map(|c| norm(sub(c.centre, centre)) + c.radius)
        .fold(0.0f64, f64::max);
    node.radius = grown.min(half_diagonal) * (1.0 + 1e-12);
    node.tail3 = node.area * node.radius.powi(3);
    node.tail4 = node.area;
    for child in [l, r] {
        translate_into(&mut node, child);
    }
    node
}

/// The box of the items' corners and the box of their centroids.
fn bounds(items: &[Item]) -> ([f64; 3], [f64; 3], [f64; 3], [f64; 3]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let (mut clo, mut chi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for item in items {
        for k in 0..3 {
            lo[k] = lo[k].min(item.lo[k]);
            hi[k] = hi[k].max(item.hi[k]);
            clo[k] = clo[k].min(item.centroid[k]);
            chi[k] = chi[k].max(item.centroid[k]);
        }
    }
    (lo, hi, clo, chi)
}

/// ∫|x − c|² dA and ∫|x − c|⁴ dA over triangle `t`: the first in closed form (A/12·(Σ|vᵢ|² + |Σvᵢ|²)), the
/// second by Strang and Fix's six-point rule, exact for polynomials of degree 4 (positive weights, so
/// rounding stays relative).
fn absolute_moments(t: &TreeTriangle, c: [f64; 3]) -> (f64, f64) {
    let v = [t.a, t.b, t.c].map(|p| sub(p, c));
    let s: [f64; 3] = std::array::from_fn(|k| v[0][k] + v[1][k] + v[2][k]);
    let mu2 = t.area / 12.0 * (dot(v[0], v[0]) + dot(v[1], v[1]) + dot(v[2], v[2]) + dot(s, s));
    const RULE: [(f64, f64, f64); 2] = [
        (
            0.223_381_589_678_011,
            0.108_103_018_168_070,
            0.445_948_490_915_965,
        ),
        (
            0.109_951_743_655_322,
            0.816_847_572_980_459,
            0.091_576_213_509_771,
        ),
    ];
    let mut mu4 = 0.0;
    for (w, a, b) in RULE {
        for k in 0..3 {
            let mut l = [b; 3];
            l[k] = a;
            let p: [f64; 3] =
                std::array::from_fn(|x| l[0] * v[0][x] + l[1] * v[1][x] + l[2] * v[2][x]);
            let r2 = dot(p, p);
            mu4 += w * r2 * r2;
        }
    }
    (mu2, mu4 * t.area)
}

/// Adds triangle `t`'s area, width and moments about `node.centre`.
// Tensor components are indexed as in the formulas.
#[allow(clippy::needless_range_loop)]
fn add_triangle(node: &mut Node, t: &TreeTriangle) {
    node.area += t.area;
    node.width += t.width;
    // N = ½ (b − a) × (c − a): the vector area.
    let n = cross(sub(t.b, t.a), sub(t.c, t.a)).map(|x| 0.5 * x);
    let v = [t.a, t.b, t.c].map(|p| sub(p, node.centre));
    let s: [f64; 3] = std::array::from_fn(|k| v[0][k] + v[1][k] + v[2][k]);
    // ∫(x − x̄) dA / A = the centroid; ∫(x − x̄)(x − x̄)ᵀ dA / A = (Σ v vᵀ + s sᵀ) / 12.
    for a in 0..3 {
        node.m0[a] += n[a];
        for b in 0..3 {
            node.m1[3 * a + b] += n[a] * s[b] / 3.0;
        }
        for b in 0..3 {
            for c in b..3 {
                let second =
                    (v[0][b] * v[0][c] + v[1][b] * v[1][c] + v[2][b] * v[2][c] + s[b] * s[c])
                        / 12.0;
                node.m2[6 * a + SYM[b][c]] += n[a] * second;
            }
        }
    }
}

/// Adds `child`'s moments, moved from its centre to `node.centre` (Δ = x̄_child − x̄_node):
/// M1 += M0 ⊗ Δ; M2_a,bc += M1_ab Δ_c + M1_ac Δ_b + M0_a Δ_b Δ_c.
#[allow(clippy::needless_range_loop)]
fn translate_into(node: &mut Node, child: &Node) {
    let dl = sub(child.centre, node.centre);
    for a in 0..3 {
        node.m0[a] += child.m0[a];
        for b in 0..3 {
            node.m1[3 * a + b] += child.m1[3 * a + b] + child.m0[a] * dl[b];
        }
        for b in 0..3 {
            for c in b..3 {
                node.m2[6 * a + SYM[b][c]] += child.m2[6 * a + SYM[b][c]]
                    + child.m1[3 * a + b] * dl[c]
                    + child.m1[3 * a + c] * dl[b]
                    + child.m0[a] * dl[b] * dl[c];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::voxel::gwn::kernel::{solid_angle, winding_sum, FOUR_PI};

    /// Seeded uniform numbers in [0, 1) (SplitMix64).
    fn uniform(mut s: u64) -> impl FnMut() -> f64 {
        move || {
            s = s.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = s;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// A seeded soup of `n` triangles of size about `size` in the unit cube.
    fn soup(n: usize, size: f64, seed: u64) -> Vec<[[f64; 3]; 3]> {
        let mut next = uniform(seed);
        (0..n)
            .map(|_| {
                let c = [next(), next(), next()];
                std::array::from_fn(|_| std::array::from_fn(|k| c[k] + size * (next() - 0.5)))
            })
            .collect()
    }

    #[test]
    fn moments_translated_up_the_tree_equal_moments_summed_directly() {
        let tris = soup(300, 0.1, 1);
        let tree = Tree::build(&tris);
        let root = tree.nodes[0];
        let mut direct = Node {
            centre: root.centre,
            ..Node::default()
        };
        for t in &tree.triangles {
            add_triangle(&mut direct, t);
        }
        let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12);
        assert!(close(&root.m0, &direct.m0));
        assert!(close(&root.m1, &direct.m1));
        assert!(close(&root.m2, &direct.m2));
        assert!((root.area - direct.area).abs() < 1e-12);
    }

    #[test]
    fn a_tree_built_in_parallel_is_the_same_tree_whatever_the_threads_and_holds_every_triangle_once(
    ) {
        // Past PARALLEL_BUILD triangles the halves are built on other threads into their own node ranges.
        let tris = soup(5 * PARALLEL_BUILD + 17, 0.01, 2);
        let built = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| Tree::build_with(tris.iter().copied(), LEAF))
        };
        let one = built(1);
        for threads in [2, 3, 8] {
            let other = built(threads);
            assert!(one.nodes == other.nodes, "{threads} threads");
            assert!(
                one.triangles
                    .iter()
                    .zip(&other.triangles)
                    .all(|(a, b)| a.a == b.a && a.b == b.b && a.c == b.c),
                "{threads} threads"
            );
        }
        assert_eq!(one.nodes.len(), node_count(tris.len(), LEAF));
        fn recursive(n: usize, leaf: usize) -> usize {
            if n <= leaf {
                1
            } else {
                1 + recursive(n / 2, leaf) + recursive(n - n / 2, leaf)
            }
        }
        for (n, leaf) in [
            (1, 1),
            (2, 1),
            (7, 2),
            (1000, 8),
            (12345, 3),
            (5 * PARALLEL_BUILD + 17, 8),
        ] {
            assert_eq!(node_count(n, leaf), recursive(n, leaf), "{n} {leaf}");
        }
        // Walk from the root: every node reached once, every leaf range disjoint, all triangles covered, each
        // triangle inside the balls of its leaf and of every node above it.
        let mut covered = vec![false; one.triangles.len()];
        let mut reached = vec![false; one.nodes.len()];
        let mut stack = vec![(0u32, Vec::<u32>::new())];
        while let Some((i, mut above)) = stack.pop() {
            assert!(!std::mem::replace(&mut reached[i as usize], true));
            let node = one.nodes[i as usize];
            above.push(i);
            if node.is_leaf() {
                assert!(node.count as usize <= LEAF);
                for k in node.first..node.first + node.count {
                    assert!(!std::mem::replace(&mut covered[k as usize], true));
                    let t = &one.triangles[k as usize];
                    for v in [t.a, t.b, t.c] {
                        for &a in &above {
                            let ball = one.nodes[a as usize];
                            assert!(norm(sub(v, ball.centre)) <= ball.radius);
                        }
                    }
                }
            } else {
                stack.push((node.first, above.clone()));
                stack.push((node.first + 1, above));
            }
        }
        assert!(covered.iter().all(|&c| c) && reached.iter().all(|&r| r));
        // The triangles are the input's, reordered.
        let key = |t: &[[f64; 3]; 3]| t.map(|v| v.map(f64::to_bits));
        let mut given: Vec<_> = tris.iter().map(key).collect();
        let mut held: Vec<_> = one
            .triangles
            .iter()
            .map(|t| key(&[t.a, t.b, t.c]))
            .collect();
        given.sort_unstable();
        held.sort_unstable();
        assert!(given == held);
    }
    /// Calls `add(u, v)` at the centroids of the n² congruent sub-triangles of the unit triangle (a
    /// centroid rule, error O(1/n²)).
    fn centroid_rule(n: usize, mut add: impl FnMut(f64, f64)) {
        let nf = n as f64;
        for i in 0..n {
            for j in 0..n - i {
                let (i, j) = (i as f64, j as f64);
                add((i + 1.0 / 3.0) / nf, (j + 1.0 / 3.0) / nf);
                if i + j + 2.0 <= nf {
                    add((i + 2.0 / 3.0) / nf, (j + 2.0 / 3.0) / nf);
                }
            }
        }
    }

    #[test]
    fn the_second_moment_of_a_triangle_is_its_integral() {
        // ∫ x xᵀ dA over a triangle by a fine midpoint rule against (Σ v vᵀ + s sᵀ)·A/12.
        let t = TreeTriangle::new([[0.2, 0.1, 0.0], [1.0, 0.3, 0.4], [0.1, 0.9, 0.2]]);
        let mut node = Node::default();
        add_triangle(&mut node, &t);
        // Centroid rule over the n² congruent sub-triangles (error O(1/n²)).
        let n = 200;
        let mut integral = [[0.0f64; 3]; 3];
        centroid_rule(n, |u: f64, v: f64| {
            let x: [f64; 3] =
                std::array::from_fn(|k| t.a[k] + u * (t.b[k] - t.a[k]) + v * (t.c[k] - t.a[k]));
            for b in 0..3 {
                for c in 0..3 {
                    integral[b][c] += x[b] * x[c];
                }
            }
        });
        let cells = (n * n) as f64;
        let nz = cross(sub(t.b, t.a), sub(t.c, t.a)).map(|x| 0.5 * x)[2];
        for b in 0..3 {
            for c in b..3 {
                let want = nz * integral[b][c] / cells;
                let got = node.m2[6 * 2 + SYM[b][c]];
                assert!(
                    (want - got).abs() < 1e-3 * got.abs().max(1e-3),
                    "{b}{c}: {want} {got}"
                );
            }
        }
    }

    #[test]
    fn tightened_tails_bound_the_absolute_moments_and_never_exceed_the_old_ones() {
        // ∫|δ|³ and ∫|δ|⁴ over every node's triangles by a fine centroid rule (n² sub-triangles),
        // against tail3 and tail4·ρ⁴; and both at most A·ρ³ and A.
        let tree = Tree::build_with(soup(120, 0.1, 21), 2);
        let n = 60;
        let nf = n as f64;
        for node in &tree.nodes {
            let (mut i3, mut i4) = (0.0f64, 0.0f64);
            let (s, e) = range_of(&tree, node);
            for t in &tree.triangles[s..e] {
                let add = |u: f64, v: f64| {
                    let x: [f64; 3] = std::array::from_fn(|k| {
                        t.a[k] + u * (t.b[k] - t.a[k]) + v * (t.c[k] - t.a[k]) - node.centre[k]
                    });
                    let r = norm(x);
                    i3 += r.powi(3) * t.area / (nf * nf);
                    i4 += r.powi(4) * t.area / (nf * nf);
                };
                centroid_rule(n, add);
            }
            let rho = node.radius;
            assert!(node.tail3 >= i3 * (1.0 - 1e-3), "{} < {i3}", node.tail3);
            assert!(node.tail4 * rho.powi(4) >= i4 * (1.0 - 1e-3));
            // ∫|δ|⁴ is exact: tail4 is it (unless capped by A).
            assert!(
                node.tail4 == node.area || (node.tail4 * rho.powi(4) - i4).abs() < 1e-3 * i4,
                "{} vs {i4}",
                node.tail4 * rho.powi(4)
            );
            assert!(node.tail3 <= node.area * rho.powi(3) && node.tail4 <= node.area);
        }
        // What it gains: the tails of single triangles and of the root, against A·ρ³ and A.
        let leaf = &tree.nodes[tree.nodes.len() - 1];
        let root = &tree.nodes[0];
        for node in [leaf, root] {
            let r3 = node.tail3 / (node.area * node.radius.powi(3));
            assert!(r3 < 0.7, "{r3}");
        }
    }

    /// The triangle slots under `node`.
    fn range_of(tree: &Tree, node: &Node) -> (usize, usize) {
        if node.is_leaf() {
            return (node.first as usize, (node.first + node.count) as usize);
        }
        let l = range_of(tree, &tree.nodes[node.first as usize]);
        let r = range_of(tree, &tree.nodes[node.first as usize + 1]);
        (l.0, r.1)
    }

    #[test]
    fn tightened_expansions_hold_at_the_points_that_attack_their_truncation() {
        // Flat caps (the worst case of the truncation: sources spread to the rim, the point in their
        // plane) and a soup, points at t = ρ/D from 0.2 to 0.88 in many directions: the exact solid angle
        // lies within the error of the expansion at the point and of the local share over a ball.
        let mut flat = Vec::new();
        for k in 0..12 {
            let step = std::f64::consts::FRAC_PI_6;
            let (a0, a1) = (k as f64 * step, (k + 1) as f64 * step);
            flat.push([
                [0.5, 0.5, 0.5],
                [0.5 + 0.1 * a0.cos(), 0.5 + 0.1 * a0.sin(), 0.5],
                [0.5 + 0.1 * a1.cos(), 0.5 + 0.1 * a1.sin(), 0.5],
            ]);
        }
        let mut checked = 0;
        let mut tightest = f64::INFINITY;
        for tris in [flat, soup(60, 0.05, 5)] {
            let tree = Tree::build_with(tris.iter().copied(), 2);
            let mut next = uniform(77);
            for (i, node) in tree.nodes.iter().enumerate() {
                let (s, e) = range_of(&tree, node);
                for t in [0.2, 0.4, 0.6, 0.75, 0.88] {
                    for _ in 0..24 {
                        let dir = [next() - 0.5, next() - 0.5, 0.05 * (next() - 0.5)];
                        let l = norm(dir);
                        let d = node.radius / t;
                        let q: [f64; 3] = std::array::from_fn(|k| node.centre[k] + d * dir[k] / l);
                        let exact: f64 = tree.triangles[s..e]
                            .iter()
                            .map(|x| x.solid_angle(q).0)
                            .sum();
                        let (v, err) = expand(node, q, d, 0.0, d - node.radius);
                        assert!(
                            (exact - v).abs() <= err,
                            "node {i} t {t}: exact {exact}, expansion {v} ± {err}"
                        );
                        if err > 1e-12 {
                            tightest = tightest.min(err / (exact - v).abs().max(1e-300));
                        }
                        let ball = Ball {
                            c: q,
                            r: 0.1 * (d - node.radius),
                            nu: 0.0,
                        };
                        if let Some(share) = tree.local_share(i as u32, &ball) {
                            let off = [0.05 * (d - node.radius), 0.0, 0.0];
                            let p: [f64; 3] = std::array::from_fn(|k| q[k] + off[k]);
                            let exact: f64 = tree.triangles[s..e]
                                .iter()
                                .map(|x| x.solid_angle(p).0)
                                .sum();
                            let hd = packed_times(&share.hessian, off);
                            let model = share.value
                                + (0..3)
                                    .map(|k| (share.gradient[k] + 0.5 * hd[k]) * off[k])
                                    .sum::<f64>();
                            assert!((exact - model).abs() <= share.err, "node {i} t {t}");
                        }
                        checked += 1;
                    }
                }
            }
        }
        assert!(
            checked > 1000 && (1.0..1e3).contains(&tightest),
            "{checked} {tightest}"
        );
    }

    #[test]
    fn every_interval_holds_the_exact_sum_at_every_point_of_the_ball() {
        // Fat triangles (caps) and thin ones (ribbons), points near and far, balls of several sizes.
        let mut tris = soup(2000, 0.08, 7);
        for t in soup(500, 0.05, 9) {
            // Ribbons: a long edge and a third corner 1e-6 off it.
            let c = [t[0][0] + 1e-6, t[0][1], t[0][2]];
            tris.push([t[0], t[1], c]);
        }
        let tree = Tree::build(&tris);
        let mut scratch = Scratch::default();
        let probes = soup(60, 0.0, 3);
        let holds = |lo: f64, hi: f64, x: f64| x >= lo - 1e-9 && x <= hi + 1e-9;
        for (theta, eps) in [(0.5, 1e-2), (0.25, 1e-6)] {
            let accept = Accept { theta, eps };
            let cell_accept = CellAccept {
                theta,
                spread: 0.2,
                point_theta: theta,
                eps,
            };
            for p in &probes {
                let c = p[0].map(|x| 1.6 * x - 0.3);
                for r in [0.0, 0.01, 0.05] {
                    let ball = Ball { c, r, nu: 0.0 };
                    let whole = tree
                        .interval(&ball, &accept, f64::INFINITY, &mut scratch)
                        .unwrap();
                    let (lo, hi) = tree.cell(&ball, &cell_accept, &mut scratch);
                    // Points of the ball: the centre and six on its surface.
                    let mut pts = vec![c];
                    for k in 0..3 {
                        for s in [-r, r] {
                            let mut q = c;
                            q[k] += s;
                            pts.push(q);
                        }
                    }
                    for q in pts {
                        let exact = winding_sum(&tris, q) * FOUR_PI;
                        assert!(
                            holds(whole.0, whole.1, exact),
                            "interval {theta} r {r}: {whole:?} {exact}"
                        );
                        // The cell's split: far interval + middle nodes at q (and over the ball) + near.
                        let near: f64 = scratch
                            .near
                            .iter()
                            .map(|&i| tree.triangles[i as usize].solid_angle(q).0)
                            .sum();
                        let (mut ml, mut mh, mut ol, mut oh) = (lo, hi, lo, hi);
                        for &i in &scratch.mid {
                            let (v, e) = tree.share_at(i, q, 0.0);
                            ml += v - e;
                            mh += v + e;
                            let (v, e) = tree.share_over(i, &ball);
                            ol += v - e;
                            oh += v + e;
                        }
                        assert!(
                            holds(ml, mh, exact - near),
                            "cell {theta} r {r}: [{ml}, {mh}] {}",
                            exact - near
                        );
                        assert!(
                            holds(ol, oh, exact - near),
                            "cell over the ball {theta} r {r}"
                        );
                        // The adaptive point query, asked to reach a width of 1e-6 (or everything exact).
                        if r == 0.0 {
                            let got = adaptive(
                                &[&tree],
                                q,
                                0.0,
                                &accept,
                                |l, h| (h - l < 1e-6).then_some((l, h)),
                                &mut scratch,
                            );
                            let (l, h) = got.expect("refined to 1e-6");
                            assert!(holds(l, h, exact), "adaptive: [{l}, {h}] {exact}");
                        }
                    }
                }
            }
        }
        // The expansion is sharp far away: a point far from everything gets a narrow interval.
        let far = Ball {
            c: [5.0, 5.0, 5.0],
            r: 0.0,
            nu: 0.0,
        };
        let (lo, hi) = tree
            .interval(
                &far,
                &Accept {
                    theta: 0.5,
                    eps: 0.0,
                },
                f64::INFINITY,
                &mut scratch,
            )
            .unwrap();
        // Width against the area seen from there: t = ρ/D ≈ 0.11 bounds the truncation by ~1 % of A/D².
        let root = &tree.nodes[0];
        let d = norm(sub(far.c, root.centre));
        assert!(hi - lo < 0.02 * root.area / (d * d), "{lo} {hi}");
    }

    #[test]
    fn the_expansion_gradient_and_hessian_are_its_derivatives_and_local_shares_hold_over_the_ball()
    {
        let tris = soup(400, 0.05, 11);
        let tree = Tree::build_with(tris.iter().copied(), 2);
        let c = [1.7, 0.4, 0.9];
        for (i, node) in tree.nodes.iter().enumerate().take(200) {
            let d = norm(sub(c, node.centre));
            if node.radius >= 0.9 * d {
                continue;
            }
            let (v, g) = expand_grad(node, c, d);
            let (v0, _) = expand(node, c, d, 0.0, d - node.radius);
            assert!(
                (v - v0).abs() <= 1e-12 * v0.abs().max(1e-12),
                "{i}: {v} vs {v0}"
            );
            for k in 0..3 {
                let hstep = 1e-6;
                let mut p = c;
                p[k] += hstep;
                let mut m = c;
                m[k] -= hstep;
                let fd = (expand(node, p, norm(sub(p, node.centre)), 0.0, 1.0).0
                    - expand(node, m, norm(sub(m, node.centre)), 0.0, 1.0).0)
                    / (2.0 * hstep);
                assert!(
                    (fd - g[k]).abs() <= 1e-5 * g.iter().map(|x| x.abs()).fold(1e-9, f64::max),
                    "{i} {k}: {fd} vs {}",
                    g[k]
                );
            }
        }
        // The Hessian is the gradient's derivative.
        for (i, node) in tree.nodes.iter().enumerate().take(200) {
            let d = norm(sub(c, node.centre));
            if node.radius >= 0.9 * d {
                continue;
            }
            let (v, g, h) = expand_hess(node, c, d);
            assert_eq!((v, g), expand_grad(node, c, d));
            let scale = h.iter().map(|x| x.abs()).fold(1e-9, f64::max);
            for (k, &(a, b)) in PACKED.iter().enumerate() {
                let hstep = 1e-6;
                let (mut p, mut m) = (c, c);
                p[b] += hstep;
                m[b] -= hstep;
                let fd = (expand_grad(node, p, norm(sub(p, node.centre))).1[a]
                    - expand_grad(node, m, norm(sub(m, node.centre))).1[a])
                    / (2.0 * hstep);
                assert!(
                    (fd - h[k]).abs() <= 1e-5 * scale,
                    "{i} ({a}, {b}): {fd} vs {}",
                    h[k]
                );
            }
        }
        // Local shares: |Ω_N(q) − v − g·δ − ½δᵀHδ| ≤ err at points of the ball (δ = q − c), for every node
        // they accept; and the error falls with the ball's radius faster than the linear model's ½r²·6A/g⁴.
        let mut checked = 0;
        for r in [0.0, 0.02, 0.1, 0.3] {
            let ball = Ball { c, r, nu: 0.0 };
            for i in 0..tree.nodes.len() as u32 {
                let Some(LocalShare {
                    value: v,
                    gradient: g,
                    hessian: h,
                    err,
                }) = tree.local_share(i, &ball)
                else {
                    continue;
                };
                let node = &tree.nodes[i as usize];
                let gap = norm(sub(c, node.centre)) - r - node.radius;
                if r > 0.0 && r <= 0.3 * gap {
                    // The linear model's error: the value's and the gradient's truncations and ½r²·6A/g⁴.
                    let (d, a) = (norm(sub(c, node.centre)), node.area);
                    let (t, one) = (node.radius / d, 1.0 - node.radius / d);
                    let linear = a / (d * d) * (4.0 * t.powi(3) / one + t.powi(4) / (one * one))
                        + r * a / d.powi(3)
                            * (20.0 * t.powi(3) / one
                                + 10.0 * t.powi(4) / (one * one)
                                + 2.0 * t.powi(5) / one.powi(3))
                        + 3.0 * r * r * a / gap.powi(4);
                    assert!(err < linear, "node {i} r {r}: {err} vs {linear}");
                    checked += 1;
                }
                let mut below: Vec<[[f64; 3]; 3]> = Vec::new();
                let mut stack = vec![i];
                while let Some(j) = stack.pop() {
                    let n = &tree.nodes[j as usize];
                    if n.is_leaf() {
                        let ts = &tree.triangles[n.first as usize..(n.first + n.count) as usize];
                        below.extend(ts.iter().map(|t| [t.a, t.b, t.c]));
                    } else {
                        stack.extend([n.first, n.first + 1]);
                    }
                }
                for q in [
                    c,
                    [c[0] + r, c[1], c[2]],
                    [c[0], c[1] - r, c[2]],
                    [c[0] - 0.6 * r, c[1] + 0.6 * r, c[2] + 0.5 * r],
                ] {
                    let exact = winding_sum(&below, q) * FOUR_PI;
                    let dq: [f64; 3] = std::array::from_fn(|k| q[k] - c[k]);
                    let quadratic: f64 = PACKED
                        .iter()
                        .zip(h)
                        .map(|(&(a, b), hk)| if a == b { 0.5 } else { 1.0 } * hk * dq[a] * dq[b])
                        .sum();
                    let model = v + (0..3).map(|k| g[k] * dq[k]).sum::<f64>() + quadratic;
                    assert!(
                        (exact - model).abs() <= err,
                        "node {i} r {r}: {exact} vs {model} ± {err}"
                    );
                }
            }
        }
        assert!(checked > 10, "{checked}");
    }

    #[test]
    fn thin_triangles_are_bounded_by_their_width() {
        let t = TreeTriangle::new([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 1e-6, 0.0]]);
        for q in [
            [0.5, 0.0, 1e-3],
            [0.5, 1e-3, 0.0],
            [2.0, 0.0, 0.0],
            [0.1, -0.01, 0.02],
        ] {
            let w = solid_angle(q, t.a, t.b, t.c).abs();
            assert!(w <= t.bound(q, 0.0), "{q:?}: {w} > {}", t.bound(q, 0.0));
        }
        assert!(t.bound([0.5, 0.0, 1e-3], 0.0) < 1e-2);
    }

    /// The width bounds where they are tightest: ribbons of every shape, points just above their spines,
    /// beside their ends and in their plane, with the caller's distance ν at the true distance (so the πw/ν
    /// form is used) or below it; the node form over a leaf of them.
    #[test]
    fn the_width_bounds_hold_at_the_points_that_attack_them() {
        let mut next = uniform(7);
        let mut worst = 0.0f64;
        let mut thin_worst = 0.0f64;
        for _ in 0..4000 {
            // A ribbon: a long edge and an apex a hair off it, anywhere along it or a little past an end (then
            // another edge is the longest).
            let a = [next(), next(), next()];
            let e = [next() - 0.5, next() - 0.5, next() - 0.5];
            let b = std::array::from_fn(|k| a[k] + e[k]);
            let h = 10f64.powf(-1.0 - 6.0 * next());
            let along = 1.4 * next() - 0.2;
            let side = cross(e, [next() - 0.5, next() - 0.5, next() - 0.5]);
            let side = side.map(|x| x / norm(side));
            let c: [f64; 3] = std::array::from_fn(|k| a[k] + along * e[k] + h * side[k]);
            let t = TreeTriangle::new([a, b, c]);
            let tri = [t.a, t.b, t.c];
            for _ in 0..20 {
                // Points at distances of the width's order and far above it, over the spine or past its ends.
                let l = 1.6 * next() - 0.3;
                let dist = h * 10f64.powf(3.0 * next() - 0.5);
                let dir = [next() - 0.5, next() - 0.5, next() - 0.5];
                let dir = dir.map(|x| x / norm(dir));
                let q: [f64; 3] = std::array::from_fn(|k| a[k] + l * e[k] + dist * dir[k]);
                let true_d = triangle_distance(q, tri[0], tri[1], tri[2]);
                let omega = solid_angle(q, tri[0], tri[1], tri[2]).abs();
                for nu in [0.0, 0.5 * true_d, true_d * (1.0 - 1e-9)] {
                    let b = t.bound(q, nu);
                    assert!(omega <= b, "{tri:?} at {q:?} (ν {nu}): {omega} > {b}");
                    if b < t.area / (true_d * true_d) * 0.5 {
                        // The width form decided: how close to it the truth comes.
                        worst = worst.max(omega / b);
                    }
                    let ball = Ball { c: q, r: 0.0, nu };
                    assert!(omega <= t.bound_over(&ball));
                }
                // Over a ball holding q: its centre moved by up to r, ν what the whole ball keeps.
                for f in [0.3, 0.9] {
                    let r = f * true_d;
                    let off = [next() - 0.5, next() - 0.5, next() - 0.5];
                    let off = off.map(|x| x / norm(off) * r * next());
                    let c: [f64; 3] = std::array::from_fn(|k| q[k] + off[k]);
                    let centre_d = triangle_distance(c, tri[0], tri[1], tri[2]);
                    let nu = ((centre_d - r) * (1.0 - 1e-9)).max(0.0);
                    let b = t.bound_over(&Ball { c, r, nu });
                    assert!(
                        omega <= b,
                        "{tri:?}, ball {c:?} r {r} holding {q:?}: {omega} > {b}"
                    );
                }
                // The node form: only the distance is known.
                let leaf = Node {
                    area: t.area,
                    width: t.width,
                    ..Node::default()
                };
                let nb = Tree::node_bound(&leaf, true_d * (1.0 - 1e-9), 0.0);
                assert!(omega <= nb, "{tri:?} at {q:?}: {omega} > node bound {nb}");
                if 4.0 * t.width < t.area / true_d {
                    thin_worst = thin_worst.max(omega / nb);
                }
            }
        }
        // Where the width decides, the truth comes within 2/π of πw/d (a flat strip seen from above its
        // spine: a lune of 2w/d), for a single triangle and for the node form alike: the bounds are as tight
        // as their proofs allow.
        assert!(worst > 0.6 && thin_worst > 0.6, "{worst} {thin_worst}");
    }
}
