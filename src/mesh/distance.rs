//! Closest points on a triangle soup: a bounding-volume hierarchy over the triangles and, per query point,
//! the nearest triangle, the closest point on it, its barycentric coordinates and the distance.
//!
//! Invariants: coordinates are f64 (the callers pass f32 positions widened, local to an origin), so the
//! distance is exact to well under an f32 ulp of the mesh's extent; every triangle counts, degenerate ones
//! too (a zero-area triangle is a segment or a point, and its closest point is found as such); the answer
//! is the nearest triangle, ties going to the lowest index, whatever the tree's shape.
//!
//! Cost model: building splits at the median centroid along the longest axis (a linear selection per
//! level), O(T log T), the halves of more than 4,096 triangles on other threads into node ranges fixed in
//! advance (the same tree whatever the threads; leaves of at most [`LEAF`] triangles). A query descends
//! nearest child first, never pushes a child farther than the best distance so far, and skips a leaf's
//! triangle whose plane or bounding sphere is farther (two cheap lower bounds before the closest-point
//! routine): O(log T) nodes for a point near a well-spread surface. Many points
//! ([`DistanceTree::closest_all`]) run in Morton order, each starting from its predecessor's triangle, whose
//! distance bounds the descent at once (whole `gregvox query stanford-bunny.obj --what udf` processes on 2
//! cores, 100,000 points: uniform in the padded box 0.55 → 0.41 s, near the surface 0.21 → 0.17 s; the
//! build 36 → 16 ms). The worst case is a point equidistant from many triangles
//! (the centre of a finely tessellated sphere): no box can be pruned and the query visits all T
//! triangles; points deep inside a round part come near it (the bunny's uniform points visit about 100
//! nodes and test about 65 triangles each). Far points cost little: the first leaf's distance prunes
//! almost everything, since every box is then about as far. Slivers attack the boxes: the fan of one huge
//! polygon puts thousands of long boxes over every point near it, so the queries' tree
//! ([`DistanceTree::new_split`]) cuts slivers (longest edge ≥ [`SLIVER`] × height) into pieces of a bounded
//! length, about length / limit pieces each (tested on a 100,000-gon's fan and a prism of two 4,000-gons,
//! benched on the prism: `gregvox bench --suite query`). The device's search
//! ([`DistanceTree::device_layout`], `passes::closest_point`) walks the same tree with the same cost per
//! point.

/// Triangles per leaf.
pub const LEAF: usize = 8;

/// [`DistanceTree::new_split`] cuts a triangle only when its longest edge is at least this many times the
/// height over it.
pub const SLIVER: f64 = 8.0;

/// The nearest triangle to a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closest {
    /// Index of the triangle (in the order given to [`DistanceTree::new`]).
    pub triangle: u32,
    /// The closest point on it.
    pub point: [f64; 3],
    /// Its barycentric coordinates (weights of the triangle's corners a, b, c; they sum to 1).
    pub barycentric: [f64; 3],
    /// The squared distance.
    pub distance2: f64,
}

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: [f64; 3],
    hi: [f64; 3],
    /// Leaf: first triangle slot; inner: first child (the second is `first + 1`).
    first: u32,
    /// Leaf: triangle count; inner: 0.
    count: u32,
}

/// A bounding-volume hierarchy over triangles, for closest-point queries.
pub struct DistanceTree {
    nodes: Vec<Node>,
    /// Triangles in leaf order, with their original indices.
    triangles: Vec<[[f64; 3]; 3]>,
    /// Each triangle's unit normal (zero for a degenerate one), parallel to `triangles`: the distance to
    /// its plane is a lower bound that skips most triangles of a visited leaf without the closest-point
    /// routine.
    normals: Vec<[f64; 3]>,
    /// Each triangle's bounding sphere (centre of its box, radius), parallel to `triangles`: the other
    /// lower bound, for triangles beside the nearest one whose planes pass close to the point.
    spheres: Vec<([f64; 3], f64)>,
    index: Vec<u32>,
}

/// A query's traversal stack (nodes with the lower bound of their distance), reused between queries.
#[derive(Clone, Debug, Default)]
pub struct Stack(Vec<(f64, u32)>);

/// Points per chunk of [`DistanceTree::closest_all`]: each chunk runs in Morton order, every point starting
/// from its predecessor's answer.
pub const CHUNK: usize = 64;

/// The unit normal of `t` (zero when degenerate).
fn unit_normal(t: &[[f64; 3]; 3]) -> [f64; 3] {
    let (u, v) = (sub(t[1], t[0]), sub(t[2], t[0]));
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let l = dot(n, n).sqrt();
    if l > 0.0 && l.is_finite() {
        n.map(|x| x / l)
    } else {
        [0.0; 3]
    }
}

/// A sphere holding `t`: its box's centre and the farthest corner from it (a little enlarged for rounding).
fn bounding_sphere(t: &[[f64; 3]; 3]) -> ([f64; 3], f64) {
    let c: [f64; 3] = std::array::from_fn(|k| {
        0.5 * (t[0][k].min(t[1][k]).min(t[2][k]) + t[0][k].max(t[1][k]).max(t[2][k]))
    });
    let r = t
        .iter()
        .map(|v| dot(sub(*v, c), sub(*v, c)))
        .fold(0.0f64, f64::max)
        .sqrt();
    (c, r * (1.0 + 1e-12))
}

/// The 30-bit Morton code of `p` in the box [lo, lo + 1/scale·1024).
fn morton(p: [f64; 3], lo: [f64; 3], scale: [f64; 3]) -> u32 {
    let spread = |x: u32| -> u32 {
        let mut x = x & 0x3ff;
        x = (x | x << 16) & 0x0300_00ff;
        x = (x | x << 8) & 0x0300_f00f;
        x = (x | x << 4) & 0x030c_30c3;
        (x | x << 2) & 0x0924_9249
    };
    let q: [u32; 3] =
        std::array::from_fn(|a| ((p[a] - lo[a]) * scale[a]).clamp(0.0, 1023.0) as u32);
    spread(q[0]) | spread(q[1]) << 1 | spread(q[2]) << 2
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The closest point of triangle (a, b, c) to p, as barycentric weights (Ericson, Real-Time Collision
/// Detection §5.1.5, by Voronoi regions; degenerate triangles fall into an edge or vertex region).
pub fn closest_on_triangle(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [f64; 3] {
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = if d1 - d3 > 0.0 { d1 / (d1 - d3) } else { 0.0 };
        return [1.0 - v, v, 0.0];
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = if d2 - d6 > 0.0 { d2 / (d2 - d6) } else { 0.0 };
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let den = (d4 - d3) + (d5 - d6);
        let w = if den > 0.0 { (d4 - d3) / den } else { 0.0 };
        return [0.0, 1.0 - w, w];
    }
    let sum = va + vb + vc;
    if sum.is_nan() || sum <= 0.0 {
        // A degenerate triangle whose regions all failed (rounding on a sliver): its nearest corner.
        let d = [a, b, c].map(|q| dot(sub(p, q), sub(p, q)));
        let k = (0..3).min_by(|&i, &j| d[i].total_cmp(&d[j])).unwrap_or(0);
        let mut w = [0.0; 3];
        w[k] = 1.0;
        return w;
    }
    let (v, w) = (vb / sum, vc / sum);
    [1.0 - v - w, v, w]
}

/// The closest point of triangle `t` to `p`: (the point, its barycentric weights, the squared distance).
pub fn closest_point(p: [f64; 3], t: &[[f64; 3]; 3]) -> ([f64; 3], [f64; 3], f64) {
    let w = closest_on_triangle(p, t[0], t[1], t[2]);
    let q = at(t, w);
    let d = sub(p, q);
    (q, w, dot(d, d))
}

fn at(t: &[[f64; 3]; 3], w: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|k| w[0] * t[0][k] + w[1] * t[1][k] + w[2] * t[2][k])
}

/// Squared distance from p to the box [lo, hi] (0 inside).
fn box_distance2(p: [f64; 3], lo: [f64; 3], hi: [f64; 3]) -> f64 {
    (0..3)
        .map(|k| {
            let d = (lo[k] - p[k]).max(0.0).max(p[k] - hi[k]);
            d * d
        })
        .sum()
}

/// Halves with more triangles than this are built on another thread.
const PARALLEL_BUILD: usize = 4096;

/// Nodes of the tree over `n` triangles (median splits, leaves of at most [`LEAF`]).
fn node_count(n: usize) -> usize {
    if n <= LEAF {
        1
    } else {
        1 + node_count(n / 2) + node_count(n - n / 2)
    }
}

/// Builds the subtree over `order` (slots `start..` of the final triangle order) into `me`, its
/// descendants into `below` (node indices from `base`): children adjacent, the left subtree's descendants
/// before the right's, so the layout — and every query's answer — is the same whatever the threads.
fn build_into(
    triangles: &[[[f64; 3]; 3]],
    order: &mut [u32],
    start: usize,
    me: &mut Node,
    below: &mut [Node],
    base: usize,
) {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for &i in order.iter() {
        for v in &triangles[i as usize] {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
    }
    me.lo = lo;
    me.hi = hi;
    if order.len() <= LEAF {
        me.first = start as u32;
        me.count = order.len() as u32;
        return;
    }
    let axis = (0..3)
        .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
        .unwrap_or(0);
    let centroid = |i: u32| -> f64 {
        let t = &triangles[i as usize];
        (t[0][axis] + t[1][axis] + t[2][axis]) / 3.0
    };
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |&a, &b| {
        centroid(a).total_cmp(&centroid(b)).then(a.cmp(&b))
    });
    me.first = base as u32;
    me.count = 0;
    let (kids, rest) = below.split_at_mut(2);
    let (left, right) = kids.split_at_mut(1);
    let left_below = node_count(mid) - 1;
    let (lb, rb) = rest.split_at_mut(left_below);
    let (lo_order, hi_order) = order.split_at_mut(mid);
    let n = lo_order.len() + hi_order.len();
    let mut build_left = move || build_into(triangles, lo_order, start, &mut left[0], lb, base + 2);
    let mut build_right = move || {
        build_into(
            triangles,
            hi_order,
            start + mid,
            &mut right[0],
            rb,
            base + 2 + left_below,
        )
    };
    if n > PARALLEL_BUILD {
        rayon::join(build_left, build_right);
    } else {
        build_left();
        build_right();
    }
}

impl DistanceTree {
    /// The tree over `triangles` (any, degenerate ones included).
    pub fn new(triangles: &[[[f64; 3]; 3]]) -> DistanceTree {
        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        let mut nodes = vec![
            Node {
                lo: [0.0; 3],
                hi: [0.0; 3],
                first: 0,
                count: 0,
            };
            node_count(triangles.len())
        ];
        if let Some((root, below)) = nodes.split_first_mut() {
            build_into(triangles, &mut order, 0, root, below, 1);
        }
        let triangles: Vec<[[f64; 3]; 3]> = order.iter().map(|&i| triangles[i as usize]).collect();
        DistanceTree {
            nodes,
            normals: triangles.iter().map(unit_normal).collect(),
            spheres: triangles.iter().map(bounding_sphere).collect(),
            triangles,
            index: order,
        }
    }

    /// The tree over `triangles` with their slivers cut into pieces no longer than about `max_edge` (the
    /// limit grows until there are at most `max_pieces`), for distances only: a piece keeps its
    /// triangle's index, and the nearest piece gives the nearest triangle's distance, but closest points
    /// and barycentric coordinates are the piece's. Long slivers (the fan of one huge polygon) get tight
    /// boxes this way, where whole they would overlap every query near them. Only slivers are cut (the
    /// longest edge at least [`SLIVER`] times the height over it): a fat triangle's box is already tight
    /// round it, and cutting every triangle of a small mesh to the limit made the tree 40 times larger for
    /// nothing (spot, 5,856 triangles, 100,000 uniform points: 112 → 486 ms). A sliver is cut into strips
    /// parallel to its longest edge and each strip into quads (two pieces each), so it costs its length /
    /// `max_edge` pieces (longest-edge bisection would cost the square of that).
    pub fn new_split(
        triangles: &[[[f64; 3]; 3]],
        max_edge: f64,
        max_pieces: usize,
    ) -> DistanceTree {
        let d2 = |a: [f64; 3], b: [f64; 3]| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>();
        // (longest edge index, its length, the height of the opposite corner over it)
        let shape = |t: &[[f64; 3]; 3]| {
            let e = [d2(t[0], t[1]), d2(t[1], t[2]), d2(t[2], t[0])];
            let k = (0..3).max_by(|&a, &b| e[a].total_cmp(&e[b])).unwrap_or(0);
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let len = e[k].sqrt();
            let ac = [0, 1, 2].map(|x| c[x] - a[x]);
            let along = if len > 0.0 {
                (0..3).map(|x| ac[x] * (b[x] - a[x])).sum::<f64>() / len
            } else {
                0.0
            };
            let height = (d2(c, a) - along * along).max(0.0).sqrt();
            (k, len, height)
        };
        // Pieces of a triangle cut by lines across its longest edge AB every `limit` (and at the foot of
        // C's altitude), each strip then into rows at most `limit` high: about (len / limit + 1) ·
        // (height / limit + 1) quads, two pieces each.
        let count = |limit: f64, t: &[[f64; 3]; 3]| -> f64 {
            let (_, len, height) = shape(t);
            if !(len.is_finite() && height.is_finite())
                || len <= limit && height <= limit
                || height * SLIVER > len
            {
                return 1.0;
            }
            2.0 * ((len / limit).ceil() + 1.0) * (height / limit).ceil().max(1.0)
        };
        let mut limit = max_edge.max(f64::MIN_POSITIVE);
        for _ in 0..64 {
            let pieces: f64 = triangles.iter().map(|t| count(limit, t)).sum();
            if pieces <= max_pieces.max(triangles.len()) as f64 || !limit.is_finite() {
                break;
            }
            limit *= (pieces / max_pieces as f64).sqrt().max(2.0);
        }
        let mut pieces = Vec::with_capacity(triangles.len());
        let mut owner = Vec::with_capacity(triangles.len());
        let lerp = |p: [f64; 3], q: [f64; 3], f: f64| -> [f64; 3] {
            std::array::from_fn(|x| p[x] + f * (q[x] - p[x]))
        };
        for (i, t) in triangles.iter().enumerate() {
            if count(limit, t) <= 1.0 {
                pieces.push(*t);
                owner.push(i as u32);
                continue;
            }
            let (k, len, _) = shape(t);
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let xc = (0..3).map(|x| (c[x] - a[x]) * (b[x] - a[x])).sum::<f64>() / (len * len);
            let xc = xc.clamp(0.0, 1.0);
            // Cuts along AB as fractions, the foot of C's altitude among them.
            let n = (len / limit).ceil().max(1.0) as usize;
            let mut cuts: Vec<f64> = (0..=n).map(|x| x as f64 / n as f64).collect();
            cuts.push(xc);
            cuts.sort_by(f64::total_cmp);
            cuts.dedup();
            // The triangle's top above fraction x of AB: on AC left of the foot, on CB right of it.
            let top = |x: f64| {
                if x <= xc {
                    if xc > 0.0 {
                        lerp(a, c, x / xc)
                    } else {
                        c
                    }
                } else if xc < 1.0 {
                    lerp(c, b, (x - xc) / (1.0 - xc))
                } else {
                    c
                }
            };
            for w in cuts.windows(2) {
                let (x0, x1) = (w[0], w[1]);
                let (b0, b1) = (lerp(a, b, x0), lerp(a, b, x1));
                let (t0, t1) = (top(x0), top(x1));
                let high = d2(b0, t0).max(d2(b1, t1)).sqrt();
                let rows = (high / limit).ceil().max(1.0) as usize;
                for j in 0..rows {
                    let (f0, f1) = (j as f64 / rows as f64, (j + 1) as f64 / rows as f64);
                    let q = [
                        lerp(b0, t0, f0),
                        lerp(b1, t1, f0),
                        lerp(b1, t1, f1),
                        lerp(b0, t0, f1),
                    ];
                    for tri in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
                        pieces.push(tri);
                        owner.push(i as u32);
                    }
                }
            }
        }
        let mut tree = DistanceTree::new(&pieces);
        for i in &mut tree.index {
            *i = owner[*i as usize];
        }
        tree
    }

    /// Whether the tree holds no triangle.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        (self.nodes.len() * std::mem::size_of::<Node>() + self.triangles.len() * (72 + 24 + 32 + 4))
            as u64
    }

    /// The nearest triangle to `p`; `None` for an empty tree.
    pub fn closest(&self, p: [f64; 3], stack: &mut Stack) -> Option<Closest> {
        self.closest_within(p, f64::INFINITY, stack)
    }

    /// The nearest triangle to `p` if one lies within squared distance `limit2` (inclusive), else `None`:
    /// every box farther than the limit is pruned from the start, so a point far from the surface costs
    /// a few box tests (the narrow-band level sets ask only within their half-width).
    pub fn closest_within(&self, p: [f64; 3], limit2: f64, stack: &mut Stack) -> Option<Closest> {
        self.closest_within_from(p, limit2, &mut None, stack)
    }

    /// [`Self::closest_within`] starting from the triangle in slot `hint` (the previous answer, for a
    /// neighbouring point), whose distance is an upper bound that prunes the descent at once; the slot of
    /// the answer is left in `hint`. The answer is the same as without the hint.
    pub fn closest_within_from(
        &self,
        p: [f64; 3],
        limit2: f64,
        hint: &mut Option<usize>,
        stack: &mut Stack,
    ) -> Option<Closest> {
        if self.triangles.is_empty() {
            return None;
        }
        let mut best = Closest {
            triangle: u32::MAX,
            point: [0.0; 3],
            barycentric: [0.0; 3],
            distance2: limit2,
        };
        let mut best_slot = None;
        if let Some(slot) = hint.filter(|&s| s < self.triangles.len()) {
            let (q, w, d2) = closest_point(p, &self.triangles[slot]);
            if d2 <= best.distance2 {
                best = Closest {
                    triangle: self.index[slot],
                    point: q,
                    barycentric: w,
                    distance2: d2,
                };
                best_slot = Some(slot);
            }
        }
        let stack = &mut stack.0;
        stack.clear();
        let root = &self.nodes[0];
        stack.push((box_distance2(p, root.lo, root.hi), 0));
        while let Some((near, n)) = stack.pop() {
            if near > best.distance2 {
                continue;
            }
            let node = &self.nodes[n as usize];
            if node.count > 0 {
                let range = node.first as usize..(node.first + node.count) as usize;
                for slot in range {
                    let t = &self.triangles[slot];
                    // The plane's distance is a lower bound (less a generous rounding margin): a triangle
                    // whose plane is farther than the best so far cannot be nearer, nor tie.
                    let ap = sub(p, t[0]);
                    let plane = dot(self.normals[slot], ap).abs()
                        - 1e-12 * (ap[0].abs() + ap[1].abs() + ap[2].abs());
                    if plane > 0.0 && plane * plane > best.distance2 {
                        continue;
                    }
                    // Its bounding sphere's distance, the same way.
                    let (c, r) = self.spheres[slot];
                    let pc = sub(p, c);
                    let far =
                        dot(pc, pc).sqrt() - r - 1e-12 * (pc[0].abs() + pc[1].abs() + pc[2].abs());
                    if far > 0.0 && far * far > best.distance2 {
                        continue;
                    }
                    let (q, w, d2) = closest_point(p, t);
                    let id = self.index[slot];
                    if d2 < best.distance2 || (d2 == best.distance2 && id < best.triangle) {
                        best = Closest {
                            triangle: id,
                            point: q,
                            barycentric: w,
                            distance2: d2,
                        };
                        best_slot = Some(slot);
                    }
                }
                continue;
            }
            // Nearer child popped first; children beyond the best so far never pushed.
            let (a, b) = (node.first, node.first + 1);
            let da = box_distance2(p, self.nodes[a as usize].lo, self.nodes[a as usize].hi);
            let db = box_distance2(p, self.nodes[b as usize].lo, self.nodes[b as usize].hi);
            let (first, second) = if da <= db {
                ((da, a), (db, b))
            } else {
                ((db, b), (da, a))
            };
            if second.0 <= best.distance2 {
                stack.push(second);
            }
            if first.0 <= best.distance2 {
                stack.push(first);
            }
        }
        *hint = best_slot.or(*hint);
        (best.triangle != u32::MAX).then_some(best)
    }

    /// The nearest triangle within squared distance `limit2` of each of `points`, in their order. The
    /// points run in Morton order, in parallel chunks of [`CHUNK`], each point starting from its
    /// predecessor's answer ([`Self::closest_within_from`]): a neighbour's triangle bounds the descent at
    /// once, where a point taken alone starts from an unbounded search. The answers are those of
    /// [`Self::closest_within`] point by point.
    pub fn closest_all(&self, points: &[[f64; 3]], limit2: f64) -> Vec<Option<Closest>> {
        use rayon::prelude::*;
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in points {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        let scale: [f64; 3] = std::array::from_fn(|a| {
            let e = hi[a] - lo[a];
            if e > 0.0 && e.is_finite() {
                1023.0 / e
            } else {
                0.0
            }
        });
        let mut order: Vec<(u32, u32)> = points
            .par_iter()
            .enumerate()
            .map(|(i, &p)| (morton(p, lo, scale), i as u32))
            .collect();
        order.par_sort_unstable();
        let found: Vec<Option<Closest>> = order
            .par_chunks(CHUNK)
            .flat_map_iter(|chunk| {
                let (mut stack, mut hint) = (Stack::default(), None);
                chunk
                    .iter()
                    .map(|&(_, i)| {
                        self.closest_within_from(points[i as usize], limit2, &mut hint, &mut stack)
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        let mut out = vec![None; points.len()];
        for (&(_, i), c) in order.iter().zip(found) {
            out[i as usize] = c;
        }
        out
    }
}

/// A node as the device reads it (glsl/closest_point.comp): the box's low corner with the first slot or
/// child, then the high corner with the count (0 for an inner node), the integers as doubles (exact below
/// 2⁵³).
pub type DeviceNode = [[f64; 4]; 2];

/// The tree as the device's search reads it ([`DistanceTree::device_layout`]): the same nodes, pieces and
/// order as the CPU's.
pub struct DeviceLayout {
    pub nodes: Vec<DeviceNode>,
    /// Three rows (x, y, z, 0) per piece, in slot order.
    pub triangles: Vec<[f64; 4]>,
    /// Each slot's triangle index (ties go to the lowest, as on the CPU).
    pub index: Vec<u32>,
    /// The most nodes on a path from the root (the device's stack must hold one more).
    pub depth: u32,
}

impl DistanceTree {
    /// The tree for the device's search (`passes::closest_point`).
    pub fn device_layout(&self) -> DeviceLayout {
        let nodes = self
            .nodes
            .iter()
            .map(|n| {
                [
                    [n.lo[0], n.lo[1], n.lo[2], n.first as f64],
                    [n.hi[0], n.hi[1], n.hi[2], n.count as f64],
                ]
            })
            .collect();
        let triangles = self
            .triangles
            .iter()
            .flat_map(|t| t.map(|v| [v[0], v[1], v[2], 0.0]))
            .collect();
        // Children come after their parents (the build lays nodes out in pre-order).
        let mut depth = vec![1u32; self.nodes.len()];
        for n in 0..self.nodes.len() {
            let node = &self.nodes[n];
            if node.count == 0 {
                for c in [node.first, node.first + 1] {
                    depth[c as usize] = depth[n] + 1;
                }
            }
        }
        DeviceLayout {
            nodes,
            triangles,
            index: self.index.clone(),
            depth: depth.into_iter().max().unwrap_or(1),
        }
    }

    /// The triangle index of `slot` (a piece's own triangle), `None` out of range.
    pub fn triangle_of(&self, slot: usize) -> Option<u32> {
        self.index.get(slot).copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Seeded numbers in [−1, 1) (xorshift64).
    fn signed_uniform(mut s: u64) -> impl FnMut() -> f64 {
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }

    fn brute(tris: &[[[f64; 3]; 3]], p: [f64; 3]) -> (u32, f64) {
        let mut best = (u32::MAX, f64::INFINITY);
        for (i, t) in tris.iter().enumerate() {
            let q = at(t, closest_on_triangle(p, t[0], t[1], t[2]));
            let d = sub(p, q);
            let d2 = dot(d, d);
            if d2 < best.1 {
                best = (i as u32, d2);
            }
        }
        best
    }

    #[test]
    fn the_tree_finds_the_brute_force_nearest_triangle_degenerate_ones_included() {
        let mut r = signed_uniform(0x1234_5678u64);
        let mut tris: Vec<[[f64; 3]; 3]> = (0..500)
            .map(|_| {
                let c = [r(), r(), r()];
                std::array::from_fn(|_| std::array::from_fn(|k| c[k] + 0.1 * r()))
            })
            .collect();
        // A segment and a point.
        tris.push([[0.0; 3], [0.5, 0.0, 0.0], [0.25, 0.0, 0.0]]);
        tris.push([[0.3, 0.3, 0.3]; 3]);
        let tree = DistanceTree::new(&tris);
        let mut stack = Stack::default();
        for _ in 0..2000 {
            let p = [1.5 * r(), 1.5 * r(), 1.5 * r()];
            let c = tree.closest(p, &mut stack).unwrap();
            let (i, d2) = brute(&tris, p);
            assert_eq!(c.distance2, d2, "{p:?}");
            assert_eq!(c.triangle, i, "{p:?}");
            let w = c.barycentric;
            assert!((w[0] + w[1] + w[2] - 1.0).abs() < 1e-12 && w.iter().all(|&x| x >= 0.0));
        }
    }

    #[test]
    fn many_points_in_morton_order_get_the_answers_of_one_point_at_a_time() {
        let mut r = signed_uniform(0x2545_F491u64);
        // A closed-ish cloud of small triangles, duplicates (ties) and a degenerate one.
        let mut tris: Vec<[[f64; 3]; 3]> = (0..3000)
            .map(|_| {
                let c = [r(), r(), r()];
                std::array::from_fn(|_| std::array::from_fn(|k| c[k] + 0.05 * r()))
            })
            .collect();
        tris.extend_from_within(0..50);
        tris.push([[0.1; 3]; 3]);
        let tree = DistanceTree::new(&tris);
        let points: Vec<[f64; 3]> = (0..5000)
            .map(|_| [2.0 * r(), 2.0 * r(), 2.0 * r()])
            .collect();
        for limit2 in [f64::INFINITY, 0.01] {
            let all = tree.closest_all(&points, limit2);
            let mut stack = Stack::default();
            for (p, c) in points.iter().zip(&all) {
                assert_eq!(*c, tree.closest_within(*p, limit2, &mut stack), "{p:?}");
            }
            assert!(
                all.iter().any(|c| c.is_some())
                    && (limit2.is_infinite() || all.iter().any(|c| c.is_none()))
            );
        }
        assert!(tree.closest_all(&[], 1.0).is_empty());
    }

    #[test]
    fn cut_into_pieces_the_tree_gives_the_same_distances_within_any_limit_slivers_included() {
        let mut r = signed_uniform(0x9E37_79B9u64);
        let mut tris: Vec<[[f64; 3]; 3]> = (0..200)
            .map(|_| std::array::from_fn(|_| std::array::from_fn(|_| r())))
            .collect();
        // A fan of slivers, a segment, a point and one huge triangle.
        for k in 0..300 {
            let (a0, a1) = (k as f64 * 0.021, (k + 1) as f64 * 0.021);
            tris.push([
                [0.0, 0.0, 0.2],
                [a0.cos(), a0.sin(), 0.2],
                [a1.cos(), a1.sin(), 0.2],
            ]);
        }
        tris.push([[0.0; 3], [0.5, 0.0, 0.0], [0.25, 0.0, 0.0]]);
        tris.push([[0.3, 0.3, 0.3]; 3]);
        tris.push([[-5.0, -5.0, -1.0], [6.0, -4.0, -1.2], [0.0, 7.0, -0.8]]);
        for (max_edge, max_pieces) in [(0.05, 1 << 20), (0.2, 1 << 20), (0.05, 5_000)] {
            let split = DistanceTree::new_split(&tris, max_edge, max_pieces);
            assert!(split.triangles.len() <= 2 * max_pieces.max(tris.len()) + 8 * tris.len());
            // Slivers are cut; a fat triangle, however large, stays whole (its box is tight already).
            let pieces_of = |i: usize| split.index.iter().filter(|&&x| x as usize == i).count();
            assert_eq!(pieces_of(tris.len() - 1), 1, "the huge fat triangle");
            if max_pieces > 100_000 {
                assert!(pieces_of(200) > 1, "a sliver of the fan");
            }
            let mut stack = Stack::default();
            for _ in 0..1500 {
                let p = [1.5 * r(), 1.5 * r(), 1.5 * r()];
                let (i, d2) = brute(&tris, p);
                let c = split.closest(p, &mut stack).unwrap();
                assert!(
                    (c.distance2 - d2).abs() <= 1e-12 * (1.0 + d2),
                    "{p:?}: {} vs {d2}",
                    c.distance2
                );
                // The piece found belongs to a nearest triangle (ties aside).
                let t = &tris[c.triangle as usize];
                let own = dot(
                    sub(p, at(t, closest_on_triangle(p, t[0], t[1], t[2]))),
                    sub(p, at(t, closest_on_triangle(p, t[0], t[1], t[2]))),
                );
                assert!(
                    (own - d2).abs() <= 1e-12 * (1.0 + d2),
                    "triangle {} not {i}",
                    c.triangle
                );
                // Within a limit: found when closer, None when farther.
                let within = split.closest_within(p, 0.04, &mut stack);
                if d2 < 0.04 * (1.0 - 1e-9) {
                    assert!(within.is_some(), "{p:?}");
                } else if d2 > 0.04 * (1.0 + 1e-9) {
                    assert!(within.is_none(), "{p:?}");
                }
            }
        }
    }

    #[test]
    fn closest_points_by_region() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]);
        assert_eq!(
            closest_on_triangle([0.5, 0.5, 3.0], a, b, c),
            [0.5, 0.25, 0.25]
        );
        assert_eq!(
            closest_on_triangle([-1.0, -1.0, 0.0], a, b, c),
            [1.0, 0.0, 0.0]
        );
        assert_eq!(
            closest_on_triangle([1.0, -1.0, 0.0], a, b, c),
            [0.5, 0.5, 0.0]
        );
        assert_eq!(
            closest_on_triangle([3.0, 3.0, 0.0], a, b, c),
            [0.0, 0.5, 0.5]
        );
    }
}
