//! A bounding-volume tree over the welded boundary's edges, for bounds on the cap term's gradient.
//!
//! The cap term w_{C'} is harmonic off the caps and its gradient is the Biot–Savart integral over their
//! boundary, the welded mesh's boundary chain (the caps' inner edges cancel): |∇Ω(q)| ≤ Σ_e |e| / d_e(q)²,
//! d_e the distance from q to edge e. Over a ball (c, r) that meets no cap triangle, Ω therefore moves by at
//! most r · Σ_e |e| / (d_e(c) − r)²: a large flat cap seen from near its middle moves little however big it
//! is, which an area bound could never say. A node bounds its edges by (total length) / (D − r − ρ)².
//!
//! [`EdgeTree::linear`] goes one order further for the classifier's boxes: the exact gradient of the near
//! edges at the centre, and a bound on the rest over the ball (the far edges' whole variation, the near
//! edges' r²·|e|/(d − r)³). Cost of either query: the nodes whose bound exceeds `eps`, O(log E) plus the
//! edges near the ball; the worst case is a ball close to a long rim of many edges (the gradient bound meets
//! it in `tests/voxel_gwn.rs`'s 10⁵-edge open tube and the bench's `gwn_worst`; the classifier makes the
//! linear model only for at most `classify::LINEAR_MAX_TRIANGLES` large-cap triangles, so its rims are
//! short).
//!
//! Invariants: segments are reordered so each leaf owns a contiguous range; children of an inner node are
//! `first` and `first + 1`; every bound is an upper bound (distances rounded down).
use super::kernel::{norm, segment_distance2};
use crate::voxel::surface::{cross, dot, sub};

/// Segments per leaf at most.
pub const LEAF: usize = 8;

#[derive(Clone, Copy, Debug, Default)]
struct Node {
    centre: [f64; 3],
    radius: f64,
    length: f64,
    first: u32,
    count: u32,
}

/// The tree of segments.
#[derive(Clone, Debug, Default)]
pub struct EdgeTree {
    nodes: Vec<Node>,
    segments: Vec<[[f64; 3]; 2]>,
}

impl EdgeTree {
    /// The tree of `segments` (local f64 end points).
    pub fn build(segments: &[[[f64; 3]; 2]]) -> EdgeTree {
        let mut segs = segments.to_vec();
        if segs.is_empty() {
            return EdgeTree::default();
        }
        let mut nodes = vec![Node::default()];
        let n = segs.len();
        build(&mut nodes, &mut segs, 0, 0, n);
        EdgeTree {
            nodes,
            segments: segs,
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        (self.nodes.len() * std::mem::size_of::<Node>()
            + self.segments.len() * std::mem::size_of::<[[f64; 3]; 2]>()) as u64
    }

    /// Walks the nodes round the ball (c, r): a node clear of the ball whose length / gap² is at most `eps`
    /// adds that to the sum returned; the segments of the others go to `segment(s, d)`, d their distance from
    /// the ball (rounded down). `None` as soon as a segment comes within `r`.
    fn walk(
        &self,
        c: [f64; 3],
        r: f64,
        eps: f64,
        stack: &mut Vec<u32>,
        mut segment: impl FnMut(&[[f64; 3]; 2], f64),
    ) -> Option<f64> {
        let mut far = 0.0;
        if self.nodes.is_empty() {
            return Some(far);
        }
        stack.clear();
        stack.push(0);
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            let gap = (norm(sub(c, node.centre)) - r - node.radius) * (1.0 - 1e-12);
            if gap > 0.0 {
                let b = node.length / (gap * gap);
                if b <= eps {
                    far += b;
                    continue;
                }
            }
            if node.count == 0 {
                stack.push(node.first);
                stack.push(node.first + 1);
                continue;
            }
            for s in &self.segments[node.first as usize..(node.first + node.count) as usize] {
                let d = (segment_distance2(c, s[0], s[1]).sqrt() - r) * (1.0 - 1e-12);
                if d <= 0.0 {
                    return None;
                }
                segment(s, d);
            }
        }
        Some(far)
    }

    /// An upper bound on Σ_e |e| / d_e(q)² over every q within `r` of `c` (∞ when an edge comes within
    /// `r`). Nodes whose bound is at most `eps` are not opened.
    pub fn gradient(&self, c: [f64; 3], r: f64, eps: f64, stack: &mut Vec<u32>) -> f64 {
        let mut near = 0.0;
        let far = self.walk(c, r, eps, stack, |s, d| {
            near += norm(sub(s[1], s[0])) * (1.0 + 1e-12) / (d * d);
        });
        far.map_or(f64::INFINITY, |f| f + near)
    }

    /// A linear model of the caps' solid angle over the ball (c, r), which must meet no cap triangle:
    /// `(g, b)` with |Ω(p) − Ω(c) − g·(p − c)| ≤ b for every p in the ball. g sums the exact Biot–Savart
    /// gradients at c of the edges near the ball; b bounds what that leaves: r·|e|/(d_e − r)² for the far
    /// edges (their whole variation, nodes whose bound is at most `eps` taken whole), and for the near ones
    /// r²·|e|/(d_e − r)³ (½r² times the bound 2|e|/d³ on the derivative of an edge's field) plus the
    /// rounding of their gradient. `None` when an edge comes within `r`.
    pub fn linear(
        &self,
        c: [f64; 3],
        r: f64,
        eps: f64,
        stack: &mut Vec<u32>,
    ) -> Option<([f64; 3], f64)> {
        let (mut g, mut b) = ([0.0f64; 3], 0.0f64);
        let far = self.walk(c, r, eps / r, stack, |s, d| {
            let len = norm(sub(s[1], s[0])) * (1.0 + 1e-12);
            let ge = segment_field(c, s[0], s[1]);
            for k in 0..3 {
                g[k] += ge[k];
            }
            b += r * r * len / (d * d * d) + r * 1e-10 * norm(ge);
        })?;
        b += r * far;
        // The sums' own rounding.
        b += r * 1e-12 * (norm(g) + b);
        Some((g, b * (1.0 + 1e-12)))
    }
}

/// The gradient at `p` of the solid angle a straight edge `a → b` contributes, oriented as the caps' rims
/// are (checked against finite differences): the Biot–Savart field of the segment, in the stable form
/// (r₁ × r₂)(|r₁| + |r₂|) / (|r₁||r₂|(|r₁||r₂| + r₁·r₂)), r₁,₂ = the ends − p.
#[inline]
pub fn segment_field(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    let (r1, r2) = (sub(a, p), sub(b, p));
    let (l1, l2) = (norm(r1), norm(r2));
    let k = (l1 + l2) / (l1 * l2 * (l1 * l2 + dot(r1, r2)));
    cross(r1, r2).map(|x| k * x)
}

fn build(nodes: &mut Vec<Node>, segs: &mut [[[f64; 3]; 2]], at: usize, start: usize, end: usize) {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let mut length = 0.0;
    for s in &segs[start..end] {
        for p in s {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        length += norm(sub(s[1], s[0]));
    }
    let centre: [f64; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
    let radius = 0.5 * norm(sub(hi, lo)) * (1.0 + 1e-12);
    let length = length * (1.0 + 1e-12);
    if end - start <= LEAF {
        nodes[at] = Node {
            centre,
            radius,
            length,
            first: start as u32,
            count: (end - start) as u32,
        };
        return;
    }
    let axis = (0..3)
        .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
        .expect("three axes");
    let mid = start + (end - start) / 2;
    segs[start..end].select_nth_unstable_by(mid - start, |p, q| {
        (p[0][axis] + p[1][axis]).total_cmp(&(q[0][axis] + q[1][axis]))
    });
    let first = nodes.len();
    nodes.push(Node::default());
    nodes.push(Node::default());
    build(nodes, segs, first, start, mid);
    build(nodes, segs, first + 1, mid, end);
    nodes[at] = Node {
        centre,
        radius,
        length,
        first: first as u32,
        count: 0,
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::voxel::gwn::kernel::solid_angle;

    #[test]
    fn the_solid_angle_of_a_disk_moves_no_more_than_its_rim_allows() {
        // A fan disk of radius 1 (64 rim edges); a ball of radius 0.05 a little above its middle.
        let n = 64;
        let rim: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                [a.cos(), a.sin(), 0.0]
            })
            .collect();
        let segments: Vec<[[f64; 3]; 2]> = (0..n).map(|i| [rim[i], rim[(i + 1) % n]]).collect();
        let tree = EdgeTree::build(&segments);
        let omega = |q: [f64; 3]| -> f64 {
            (0..n)
                .map(|i| solid_angle(q, [0.0; 3], rim[i], rim[(i + 1) % n]))
                .sum()
        };
        let (c, r) = ([0.1, 0.2, 0.1], 0.05);
        let g = tree.gradient(c, r, 0.0, &mut Vec::new());
        let at_c = omega(c);
        for q in [
            [0.15, 0.2, 0.1],
            [0.1, 0.15, 0.1],
            [0.1, 0.2, 0.06],
            [0.07, 0.23, 0.13],
        ] {
            assert!((omega(q) - at_c).abs() <= r * g, "{q:?}");
        }
        // Far from the rim the bound is small although the disk fills half the sky.
        assert!(r * g < 0.6 && at_c.abs() > 5.0, "{} {at_c}", r * g);
        // The linear model: the gradient at c is the finite difference's, and the model holds over the ball.
        let (grad, bound) = tree.linear(c, r, 0.0, &mut Vec::new()).unwrap();
        let h = 1e-6;
        for k in 0..3 {
            let (mut up, mut down) = (c, c);
            up[k] += h;
            down[k] -= h;
            let fd = (omega(up) - omega(down)) / (2.0 * h);
            assert!(
                (fd - grad[k]).abs() < 1e-6 * (1.0 + fd.abs()),
                "{k}: {fd} {grad:?}"
            );
        }
        for q in [
            [0.15, 0.2, 0.1],
            [0.1, 0.15, 0.1],
            [0.1, 0.2, 0.06],
            [0.07, 0.23, 0.13],
        ] {
            let d: [f64; 3] = std::array::from_fn(|k| q[k] - c[k]);
            let model = at_c + (0..3).map(|k| grad[k] * d[k]).sum::<f64>();
            assert!((omega(q) - model).abs() <= bound, "{q:?}");
        }
        // Tighter than the gradient bound, which moves by r·|∇| whatever the direction.
        assert!(bound < 0.2 * r * g, "{bound} {}", r * g);
        assert!(tree
            .linear([1.0, 0.0, 0.01], 0.05, 0.0, &mut Vec::new())
            .is_none());
        // And infinite when the ball reaches the rim.
        assert!(tree
            .gradient([1.0, 0.0, 0.01], 0.05, 0.0, &mut Vec::new())
            .is_infinite());
    }
}
