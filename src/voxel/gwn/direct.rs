//! The direct evaluation: voxels of the near zone and voxels no box bound labelled, one by one.
//!
//! At such a voxel q: n = the exact winding number of the closed chain M ∪ X at q (`super::crossing`,
//! exact predicates: right however close q is to the surface), then the tree's interval for w_X at q with
//! no distance assumed (its near leaves summed exactly), so w_M = n − w_X ∈ [n − hi, n − lo]; while that
//! interval straddles ½ the shares with the largest errors are opened (`Tree::adaptive`). A voxel still
//! undecided with every leaf exact (|w_M| within rounding of ½), or one lying on a triangle (`super::zone`'s
//! on-surface list, or the crossing count's own finding), gets
//! the plain sum of M's solid angles in triangle order: the reference the decision is defined by.
//!
//! Cost per voxel: a bucket of the crossing index, one tree traversal with its near triangles summed
//! exactly; the plain O(|M|) sum only where no bound separates w from ½.
//!
//! Where the time goes on a surface strewn with holes (measured 2026-12-06 on the bunny with a third of its
//! triangles removed, 256³: 36,155 direct voxels, about a quarter of the process): the voxels are not
//! intrinsically close to ½ — of a sample of 698, 9 had ||w| − ½| below 1e-3, 115 below 1e-2 and the rest
//! 0.01–0.5 — but the order-2 expansions' truncation bounds add up without cancelling, about
//! 4.5θ³·2πσ·ln(D_max/D_min) steradians over a surface a fraction σ of which is cap, so separating a margin
//! of 0.01–0.1 needs θ near 0.1–0.2 and thousands of shares per voxel. The refinement order is not the
//! limit: a max-heap opening the worst share first (or the worst half of the error per round) made the
//! same decisions 10–20 % slower than opening the worst quarter per round. What did cut them: bounding each
//! cap node's truncation by its own absolute moments instead of A·ρⁿ (`Tree::tighten_tails`, 2026-12-07):
//! the same grid with 22,522 direct voxels in 0.75 s instead of 36,155 in 1.98 s.
//!
//! Higher-order expansions were measured too (2026-12-06, an experiment not merged: Cartesian Taylor
//! coefficients of 1/|y| by their recurrence, and the moments folded into traceless form so a point costs
//! one polynomial in y/|y|, both checked against the exact sums with rigorous tails A/D²·Σ_(n≥p+2) n·tⁿ⁻¹).
//! An order-4 value cost 3–4× the hand-written order-2 one (about 200 against 50 ns), while at a fixed error
//! it accepts nodes only about (θ₂/θ₄)² ≈ 0.44× as many: break-even for decisions whose margins are
//! 0.01–0.5, and slower as wired (direct 1.7 → 3.0 s, labelling 7.7 → 10.2 s on a third of the bunny removed
//! at 192³, the same grids). They pay only for tight values (winding numbers within 1e-6, where order 2
//! needs θ ≈ 0.01); what would cut the decisions is a cheaper far field per voxel (shared local expansions
//! of higher order, as a fast multipole method's), not a costlier one per node.
use super::classify::{Fractional, Limits, Scratches, SLACK};
use super::kernel::FOUR_PI;
use super::tree::Accept;
use super::zone::{centre, unlinear};
use crate::error::{Error, Result};
use crate::voxel::grid::GridFrame;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// The first traversal of a direct voxel (then the worst shares are opened until it is decided).
pub const FIRST: Accept = Accept {
    theta: 0.35,
    eps: 1e-3,
};

/// Which decision: |w| ≥ ½ (the default rule) or w ≥ ½ (`--rule gwn-positive`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Inside {
    Magnitude,
    Positive,
}

impl Inside {
    /// The decision for w in [a, b], if the interval settles it.
    pub fn of_interval(self, a: f64, b: f64) -> Option<bool> {
        match self {
            Inside::Magnitude => {
                if a >= 0.5 + SLACK || b <= -0.5 - SLACK {
                    Some(true)
                } else if a > -0.5 + SLACK && b < 0.5 - SLACK {
                    Some(false)
                } else {
                    None
                }
            }
            Inside::Positive => {
                if a >= 0.5 + SLACK {
                    Some(true)
                } else if b < 0.5 - SLACK {
                    Some(false)
                } else {
                    None
                }
            }
        }
    }

    /// The decision for the value w itself.
    pub fn of_value(self, w: f64) -> bool {
        match self {
            Inside::Magnitude => w.abs() >= 0.5,
            Inside::Positive => w >= 0.5,
        }
    }
}

/// What the direct evaluation did.
#[derive(Clone, Copy, Debug, Default)]
pub struct DirectCounts {
    /// Voxels the first traversal left undecided (decided by opening nodes).
    pub refined: u64,
    /// Voxels decided by the plain sum over the mesh.
    pub plain_sums: u64,
}

/// Decides each voxel of `voxels` (linear indices): `Ok(answers)` in their order. `count(i, q)` is the
/// exact winding number of M ∪ X at the centre q of `voxels[i]` (`None` when q lies on the chain),
/// `plain_sum(q)` M's own winding number by the plain sum in triangle order.
#[allow(clippy::too_many_arguments)]
pub fn decide(
    frame: &GridFrame,
    voxels: &[u64],
    x: &Fractional,
    count: &(dyn Fn(usize, [f64; 3]) -> Option<i32> + Sync),
    plain_sum: &(dyn Fn([f64; 3]) -> f64 + Sync),
    on_surface: &[u64],
    inside: Inside,
    limits: &Limits,
) -> Result<(Vec<bool>, DirectCounts)> {
    let (refined, plain) = (AtomicU64::new(0), AtomicU64::new(0));
    let answers: Vec<bool> = voxels
        .par_iter()
        .enumerate()
        .map_init(Scratches::default, |scratch, (slot, &id)| {
            if limits.expired() {
                return false;
            }
            let q = centre(frame, unlinear(frame, id));
            let on = on_surface.binary_search(&id).is_ok();
            if let Some(n) = (!on).then(|| count(slot, q)).flatten() {
                let mut rounds = 0u32;
                let decided = x.adaptive(
                    q,
                    0.0,
                    &FIRST,
                    |lo, hi| {
                        rounds += 1;
                        inside.of_interval(n as f64 - hi / FOUR_PI, n as f64 - lo / FOUR_PI)
                    },
                    scratch,
                );
                if let Some(answer) = decided {
                    if rounds > 1 {
                        refined.fetch_add(1, Ordering::Relaxed);
                    }
                    return answer;
                }
            }
            plain.fetch_add(1, Ordering::Relaxed);
            let w = plain_sum(q);
            inside.of_value(w)
        })
        .collect();
    if limits.expired() {
        return Err(Error::Timeout {
            seconds: limits.seconds,
            stage: "deciding the voxels near the surface".into(),
        });
    }
    Ok((
        answers,
        DirectCounts {
            refined: refined.into_inner(),
            plain_sums: plain.into_inner(),
        },
    ))
}
