//! Point queries: the exact generalized winding number, occupancy, unsigned and signed distance at any
//! points (the dataset builders' inputs: Occupancy Networks, DeepSDF, IF-Net), one call per operation
//! (libigl style) or a [`MeshQuery`] prepared once for many batches of points.
//!
//! # Definitions
//! - The mesh: every face fanned from its first vertex, positions as f32 in the mesh's local frame (as
//!   voxelize); the winding number takes the same hygiene as voxelize (exact duplicate triangles once,
//!   opposite pairs cancelled, zero-area triangles dropped); distances take every triangle as given.
//! - `winding`: the exact winding number w at the point, with an error below [`QueryOptions::tolerance`]
//!   (default 1e-6); a closed mesh gives an exact integer. `occupancy`: |w| ≥ ½ ([`Inside::Magnitude`],
//!   `--rule gwn`) or w ≥ ½ ([`Inside::Positive`], `--rule gwn-positive`, libigl's convention), decided
//!   from rigorous bounds, never from a rounded value near ½.
//! - Points exactly on a triangle: w is not defined there (it jumps across the surface). gregvox returns
//!   what libigl's `winding_number` returns, the plain sum of the Van Oosterom–Strackee solid angles of
//!   the triangles in order (a triangle through the point contributing 0 or ½ by its atan2), and decides
//!   occupancy from it; the distance there is 0 and so is the signed distance.
//! - `udf`: the distance to the nearest triangle, computed in f64 and rounded to f32, with that triangle
//!   (`face`: its index in the fan triangulation; for a triangle mesh, the face), the closest point and its
//!   barycentric coordinates. `sdf`: udf signed by occupancy, negative inside by default
//!   ([`SdfSign::InsideNegative`], as libigl, Open3D and Warp) or positive inside
//!   ([`SdfSign::InsidePositive`], as trimesh and pysdf). The sign comes from the winding number, so it is
//!   right on open, unwelded and self-intersecting meshes, where ray parity and normals are not.
//!
//! # Cost model
//! Preparing: the hygiene and the weld O(T log T); caps, ribbons and their trees O(X log X) (X = cap and
//! ribbon triangles: nothing on a closed mesh); the crossing index O(T + X), or, where the weld moved
//! vertices (a soup: about six ribbons a triangle), O(T) for the welded mesh and the moved triangles' prisms
//! (`voxel::gwn::welded::WeldedChain`: the unwelded bunny's 100,000 uniform occupancies, the same answers in
//! about 10 % less CPU time and 5 % less memory than with M ∪ X indexed); the distance tree
//! O(P log P) over P ≤ max(9T/8, 2^18) pieces (slivers cut to a 128th of the extent, so a huge
//! polygon's fan does not overlap every query near it; fat triangles stay whole). A job computes
//! occupancy once and searches the nearest triangles once, whatever it asks of winding, occupancy, sdf
//! and udf. Per point: a bucket of the crossing index (the
//! exact integer winding number of the closed chain M ∪ X; near a moved triangle, its prism's few exact
//! tests too), then, on an open mesh, one traversal of X's
//! trees refined until the interval is narrower than the tolerance (near a cap, down to its exact
//! triangles); distances: O(log P) nodes near a spread surface. Occupancy (and the sign of sdf) shares
//! bounds between points as voxelize shares them between voxels: an octree over the points, where a cell
//! whose ball gets an interval of w_X strictly inside (k − ½, k + ½) decides all its points from their
//! crossing counts against k; only the points of cells no bound settles (at most 32 points a leaf, or near
//! X) are traversed one by one, from a looser first traversal than a value's (`DECIDE_FIRST`: most points
//! are far from ½ and need few nodes).
//!
//! The worst cases: winding values (tight tolerances) among thousands of small caps, where the bounds
//! converge slowly: the refinement stops after about T/4 share evaluations and the plain sum over
//! M answers (exact up to rounding), so a point never costs more than about 1¼ plain sums (measured:
//! 0.8 ms per point on the bunny with a third of its triangles removed, 2 cores, against 3.6 ms
//! without the limit); and for distances a point equidistant from every triangle (the centre of a fine
//! sphere visits them all). Points run in parallel on every core; distances in Morton order, each point
//! starting from its predecessor's triangle (`DistanceTree::closest_all`).
//!
//! # On the device
//! [`MeshQuery::unsigned_distance_on`] and [`MeshQuery::signed_distance_on`] search the nearest pieces on
//! a Vulkan device (`passes::closest_point`): in f64, the CPU's search operation for operation, every
//! intermediate unfused, and each quotient corrected to the one IEEE division gives (Vulkan rounds f64
//! add, subtract and multiply correctly, not division), so the device finds the CPU's pieces and the rows
//! are the CPU's bit for bit. [`MeshQuery::distances_on`] with `verify` also checks every answer on the
//! host (`gregvox query --device-check`): the device's piece starts the CPU's own search, which returns the
//! CPU's answer whatever the device computed, and [`DeviceCheck`] counts the differences. That check costs
//! about a whole CPU search (proving that nothing is nearer is most of a search's work), so it is a test,
//! not the default.
use super::{fan_local, local_origin, Mesh};
use crate::error::{Error, Result};
use crate::mesh::distance::{closest_point, DistanceTree, Stack};
use crate::voxel::gwn::classify::Scratches;
use crate::voxel::gwn::crossing::Crossings;
use crate::voxel::gwn::tree::Accept;
use crate::voxel::gwn::welded::WeldedChain;
use crate::voxel::gwn::{direct::FIRST, FractionalField, Inside, Proxy, FOUR_PI};
use crate::voxel::mesh::TriMesh;
use rayon::prelude::*;

/// How the distance is signed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SdfSign {
    /// Negative inside (libigl, Open3D, Warp). The default.
    #[default]
    InsideNegative,
    /// Positive inside (trimesh, pysdf).
    InsidePositive,
}

/// Options of the point queries.
#[derive(Clone, Copy, Debug)]
pub struct QueryOptions {
    /// Which winding numbers are inside: |w| ≥ ½ (the default) or w ≥ ½.
    pub inside: Inside,
    /// How [`MeshQuery::signed_distance`] signs.
    pub sdf_sign: SdfSign,
    /// The largest error of a returned winding number (default 1e-6).
    pub tolerance: f64,
    /// Bytes the trees and indices may take (default 1 GiB).
    pub budget: u64,
}

impl Default for QueryOptions {
    fn default() -> Self {
        QueryOptions {
            inside: Inside::Magnitude,
            sdf_sign: SdfSign::InsideNegative,
            tolerance: 1e-6,
            budget: 1 << 30,
        }
    }
}

/// Distances with their nearest triangles, one entry per point in order.
#[derive(Clone, Debug, Default)]
pub struct Distances {
    /// Unsigned, or signed as asked.
    pub distance: Vec<f32>,
    /// The closest point on the surface.
    pub closest: Vec<[f64; 3]>,
    /// The nearest triangle (index in the fan triangulation of the faces).
    pub face: Vec<u32>,
    /// Barycentric coordinates of the closest point in that triangle.
    pub barycentric: Vec<[f64; 3]>,
}

/// What the host did after a device's distance search ([`MeshQuery::distances_on`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct DeviceCheck {
    /// Points whose device search stopped at its node limit (lavapipe ends a shader's loops after 65,535
    /// iterations): the host finished them from the device's best piece.
    pub incomplete: usize,
    /// Points the host searched again from the device's answer (all of them when verifying, else the
    /// incomplete ones).
    pub checked: usize,
    /// Checked points whose complete device search named another triangle than the host's: 0 on a device
    /// whose f64 add, subtract and multiply round as Vulkan requires (the search mirrors the CPU's and
    /// rounds its own quotients).
    pub corrected: usize,
}

/// The nearest triangles of some points ([`MeshQuery::nearest_triangles`]).
#[derive(Clone, Debug)]
pub struct Nearest {
    /// The points in the prepared mesh's local frame.
    local: Vec<[f64; 3]>,
    /// The nearest triangle of each point (index in the fan triangulation).
    pub faces: Vec<u32>,
    /// What the host did after a device's search (zeros for the CPU's).
    pub check: DeviceCheck,
}

/// A mesh prepared for point queries: the fractional term's trees, the crossing index and the distance
/// tree, built once. Thread-safe; each call runs its points in parallel.
pub struct MeshQuery {
    opts: QueryOptions,
    /// World = local + shift.
    shift: [f64; 3],
    /// The cleaned triangles' count (the first ones of the crossing chain).
    mesh_triangles: usize,
    /// `None` when prepared for distances only.
    crossings: Option<Counts>,
    field: Option<FractionalField>,
    /// Built on the first distance query (occupancy and winding numbers never need it).
    distance: std::sync::OnceLock<DistanceTree>,
    /// The distance tree as the device reads it, made on the first device query and kept.
    device_layout: std::sync::OnceLock<crate::mesh::distance::DeviceLayout>,
    /// Every fanned triangle, local (what distances and the samplers see).
    triangles: Vec<[[f64; 3]; 3]>,
}

/// The first traversal of a point whose occupancy alone is asked (then the worst shares are opened until it
/// is decided). Looser than the value's and the voxels' direct step ([`FIRST`]: θ 0.35, ε 10⁻³): most
/// scattered points have |w| far from ½ (on a third of the bunny, 85 % of uniform points more than 0.3 from
/// it), and for them the tight first traversal was most of the cost. Measured on 100,000 points, uniform and
/// near the surface, alternating runs (`gregvox query MESH --sample … --what occupancy`): a third of the
/// bunny 0.76 → 0.58 s and 1.68–1.83 → 1.59–1.66 s, the unwelded soup 0.59 → 0.50 s and 1.12–1.30 →
/// 0.87–0.89 s, 300 open shells 0.74 → 0.41 s and 1.11–1.22 → 0.88–0.92 s, the bunny with 5 % removed
/// 0.39 → 0.26 s and 0.69–0.88 → 0.50 s, the closed bunny, the teapot and the chair within noise or a little
/// faster; the same occupancies everywhere (θ 0.6–0.7 and ε 3·10⁻² were no better).
const DECIDE_FIRST: Accept = Accept {
    theta: 0.5,
    eps: 1e-2,
};

/// A soup's points are counted on the welded mesh and the prisms ([`WeldedChain`]) unless a query could
/// have to test more than this many prisms' boxes (then on M ∪ X).
const WELDED_BUCKET: usize = 256;

/// The exact integer winding number of the closed chain M ∪ X at a point (`None` on one of its
/// triangles), and M's plain sum.
enum Counts {
    /// M ∪ X indexed whole, M's triangles first.
    Whole(Crossings),
    /// A soup the weld moved: M' ∪ C' and the prisms of the moved triangles (`voxel::gwn::welded`).
    Welded(Box<WeldedChain>),
}

impl Counts {
    fn winding(&self, q: [f64; 3]) -> Option<i32> {
        match self {
            Counts::Whole(c) => c.winding(q),
            Counts::Welded(c) => c.winding(q),
        }
    }

    /// M's winding number at `q` by the plain sum in triangle order (M has `mesh_triangles`).
    fn plain_sum(&self, q: [f64; 3], mesh_triangles: usize) -> f64 {
        match self {
            Counts::Whole(c) => c.plain_sum(q, mesh_triangles),
            Counts::Welded(c) => c.plain_sum(q),
        }
    }
}

/// Points in an octree cell below which they are decided one by one.
const CELL_POINTS: usize = 32;

/// The length scale the weld works at: as voxelize at 256³ (a 512th of a voxel of a 256³ grid spanning the
/// mesh's longest side).
const WELD_RES: f64 = 256.0;

impl MeshQuery {
    /// Prepares `mesh` (at least one triangle of non-zero area).
    pub fn new(mesh: &Mesh, opts: &QueryOptions) -> Result<MeshQuery> {
        MeshQuery::prepare(mesh, opts, true)
    }

    /// Prepares `mesh` for [`MeshQuery::unsigned_distance`] alone: no weld, caps or crossing index (on an
    /// unwelded soup, most of the preparation). The winding number, occupancy and signed distance then
    /// answer an error.
    pub fn distances_only(mesh: &Mesh, opts: &QueryOptions) -> Result<MeshQuery> {
        MeshQuery::prepare(mesh, opts, false)
    }

    fn prepare(mesh: &Mesh, opts: &QueryOptions, winding: bool) -> Result<MeshQuery> {
        if opts.tolerance.is_nan() || opts.tolerance <= 0.0 {
            return Err(Error::Invalid(format!(
                "the winding number's tolerance must be positive, not {}",
                opts.tolerance
            )));
        }
        let shift = local_origin(mesh);
        let fan = fan_local(mesh, shift);
        let all: Vec<[[f64; 3]; 3]> = fan
            .triangles
            .iter()
            .map(|t| t.map(|v| fan.positions[v as usize].map(f64::from)))
            .collect();
        let (tri, _) = fan.clean();
        if tri.triangles.is_empty() {
            return Err(Error::Mesh(
                "no triangle with a non-zero area to query".into(),
            ));
        }
        let distance_bytes = distance_pieces(all.len()) as u64 * DISTANCE_PIECE_BYTES;
        if distance_bytes > opts.budget {
            return Err(Error::Budget {
                what: format!("the distance tree of {} triangles", all.len()),
                detail: format!("the query budget of {} MiB", opts.budget >> 20),
            });
        }
        if !winding {
            return Ok(MeshQuery {
                opts: *opts,
                shift,
                mesh_triangles: tri.triangles.len(),
                crossings: None,
                field: None,
                distance: std::sync::OnceLock::new(),
                device_layout: std::sync::OnceLock::new(),
                triangles: all,
            });
        }
        let extent = extent(&tri);
        let h = extent / WELD_RES;
        let proxy = Proxy::new(&tri, h / 512.0)?;
        let field = if proxy.is_trivial() {
            None
        } else {
            Some(FractionalField::build(
                &tri,
                &proxy,
                [0.0; 3],
                h,
                opts.budget,
            )?)
        };
        let mesh_triangles = tri.triangles.len();
        // M ∪ X indexed whole; or, where the weld moved vertices (a soup's ribbons, about six a triangle, are
        // most of X), the welded mesh and the moved triangles' prisms.
        let counts = match &field {
            Some(f) if !proxy.ribbons.is_empty() => {
                let axis = crate::voxel::gwn::crossing::ray_axis(&[&f.mesh, &f.x]);
                match WeldedChain::new(&tri, &proxy, [0.0; 3], axis, WELDED_BUCKET) {
                    Some(welded) => Counts::Welded(Box::new(welded)),
                    None => {
                        let mut chain = f.mesh.clone();
                        chain.extend_from_slice(&f.x);
                        Counts::Whole(Crossings::with_flat_triangles(chain))
                    }
                }
            }
            _ => {
                let mut chain = crate::voxel::gwn::local_triangles(&tri, [0.0; 3]);
                if let Some(f) = &field {
                    chain.extend_from_slice(&f.x);
                }
                Counts::Whole(Crossings::with_flat_triangles(chain))
            }
        };
        Ok(MeshQuery {
            opts: *opts,
            shift,
            mesh_triangles,
            crossings: Some(counts),
            field,
            distance: std::sync::OnceLock::new(),
            device_layout: std::sync::OnceLock::new(),
            triangles: all,
        })
    }

    fn local(&self, p: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|a| p[a] - self.shift[a])
    }

    /// The winding number at local `q` (within the tolerance when `value`, else only as exact as the
    /// decision needs) and whether it is inside.
    fn winding_at(&self, q: [f64; 3], value: bool, scratch: &mut Scratches) -> (f64, bool) {
        let inside = self.opts.inside;
        let crossings = self
            .crossings
            .as_ref()
            .expect("callers check the winding part first (needs_winding)");
        if let Some(n) = crossings.winding(q) {
            let Some(field) = &self.field else {
                return (n as f64, inside.of_value(n as f64));
            };
            let tol = if value {
                self.opts.tolerance * FOUR_PI
            } else {
                f64::INFINITY
            };
            // For a value, the first traversal already aims at the tolerance (each accepted share's
            // bound below it), so that few rounds of opening follow.
            let accept = if value {
                Accept {
                    theta: FIRST.theta,
                    eps: (tol * 0.25).min(FIRST.eps),
                }
            } else {
                DECIDE_FIRST
            };
            // Past the work of a plain sum over M, the plain sum (exact up to rounding) is the cheaper
            // answer: near thousands of small caps the bounds converge slowly.
            scratch.caps.work_limit = (self.mesh_triangles as u64 / 4).max(64);
            let decided = field.fractional.adaptive(
                q,
                0.0,
                &accept,
                |lo, hi| {
                    let (a, b) = (n as f64 - hi / FOUR_PI, n as f64 - lo / FOUR_PI);
                    let inside = inside.of_interval(a, b)?;
                    (hi - lo <= 2.0 * tol).then_some((0.5 * (a + b), inside))
                },
                scratch,
            );
            if let Some(answer) = decided {
                return answer;
            }
        }
        // On a triangle, or no bound settles it: the plain sum over M, libigl's formula.
        let w = crossings.plain_sum(q, self.mesh_triangles);
        (w, inside.of_value(w))
    }

    fn check(points: &[[f64; 3]]) -> Result<()> {
        if let Some(i) = points.iter().position(|p| p.iter().any(|x| !x.is_finite())) {
            return Err(Error::Invalid(format!(
                "point {i} is not finite: {:?}",
                points[i]
            )));
        }
        Ok(())
    }

    fn needs_winding(&self) -> Result<()> {
        match self.crossings {
            Some(_) => Ok(()),
            None => Err(Error::Invalid(
                "this mesh was prepared for unsigned distances only (MeshQuery::distances_only): \
                 winding numbers, occupancy and signed distances need MeshQuery::new"
                    .into(),
            )),
        }
    }

    fn evaluate(&self, points: &[[f64; 3]], value: bool) -> Result<(Vec<f64>, Vec<bool>)> {
        self.needs_winding()?;
        Self::check(points)?;
        Ok(points
            .par_iter()
            .map_init(Scratches::default, |s, &p| {
                self.winding_at(self.local(p), value, s)
            })
            .unzip())
    }

    /// Winding numbers (within [`QueryOptions::tolerance`]) and occupancies at `points` (world
    /// coordinates).
    pub fn winding_and_occupancy(&self, points: &[[f64; 3]]) -> Result<(Vec<f64>, Vec<bool>)> {
        self.evaluate(points, true)
    }

    /// Exact winding numbers at `points` (within [`QueryOptions::tolerance`]).
    pub fn winding_numbers(&self, points: &[[f64; 3]]) -> Result<Vec<f64>> {
        Ok(self.evaluate(points, true)?.0)
    }

    /// Whether each point is inside (the rule of [`QueryOptions::inside`]), decided by bounds: the
    /// winding number is refined only until its interval leaves ½.
    pub fn occupancy(&self, points: &[[f64; 3]]) -> Result<Vec<bool>> {
        self.needs_winding()?;
        Self::check(points)?;
        let Some(field) = &self.field else {
            // Closed: the crossing count alone.
            return Ok(self.evaluate(points, false)?.1);
        };
        // Points share bounds as voxels do: an octree over the points; a cell whose ball gets an interval
        // of w_X strictly inside (k − ½, k + ½) decides each of its points from the crossing count
        // against k, the rest go one by one.
        let local: Vec<[f64; 3]> = points.iter().map(|&p| self.local(p)).collect();
        let mut out = vec![false; points.len()];
        let mut order: Vec<u32> = (0..points.len() as u32).collect();
        let (lo, hi) = bounds(local.iter().copied());
        let answers = std::sync::Mutex::new(Vec::new());
        if !points.is_empty() {
            self.occupancy_cell(field, &local, &mut order, lo, hi, 0, &answers);
        }
        for (i, o) in answers.into_inner().unwrap_or_else(|e| e.into_inner()) {
            out[i as usize] = o;
        }
        Ok(out)
    }

    /// Decides the points `idx` (into `local`) inside the box [lo, hi]; see [`MeshQuery::occupancy`].
    #[allow(clippy::too_many_arguments)]
    fn occupancy_cell(
        &self,
        field: &FractionalField,
        local: &[[f64; 3]],
        idx: &mut [u32],
        lo: [f64; 3],
        hi: [f64; 3],
        depth: u32,
        answers: &std::sync::Mutex<Vec<(u32, bool)>>,
    ) {
        let one_by_one = |idx: &[u32]| {
            let found: Vec<(u32, bool)> = idx
                .par_iter()
                .map_init(Scratches::default, |s, &i| {
                    (i, self.winding_at(local[i as usize], false, s).1)
                })
                .collect();
            answers
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .extend(found);
        };
        if idx.len() <= CELL_POINTS || depth >= 16 {
            one_by_one(idx);
            return;
        }
        let c: [f64; 3] = std::array::from_fn(|a| 0.5 * (lo[a] + hi[a]));
        let r = 0.5 * (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt();
        let ball = crate::voxel::gwn::tree::Ball { c, r, nu: 0.0 };
        let accept = Accept {
            theta: 0.5,
            eps: FIRST.eps,
        };
        let k = {
            let mut s = crate::voxel::gwn::tree::Scratch::default();
            let x = &field.fractional;
            let mut total = Some((0.0, 0.0));
            for tree in [&x.caps, &x.large, &x.ribbons] {
                total = total.and_then(|(a, b)| {
                    tree.interval(&ball, &accept, FOUR_PI, &mut s)
                        .map(|(l, h)| (a + l, b + h))
                });
            }
            total.and_then(|(l, h)| crate::voxel::gwn::classify::label(l, h))
        };
        if let Some(k) = k {
            let inside = self.opts.inside;
            let crossings = self.crossings.as_ref().expect("checked by occupancy");
            let found: Vec<(u32, bool)> = idx
                .par_iter()
                .map_init(Scratches::default, |s, &i| {
                    let q = local[i as usize];
                    let answer = match crossings.winding(q) {
                        // w = n − w_X with w_X ∈ (k − ½, k + ½): |w| ≥ ½ iff n ≠ k; w ≥ ½ iff n > k.
                        Some(n) => match inside {
                            Inside::Magnitude => n != k,
                            Inside::Positive => n > k,
                        },
                        None => self.winding_at(q, false, s).1,
                    };
                    (i, answer)
                })
                .collect();
            answers
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .extend(found);
            return;
        }
        // Split at the centre into octants, in parallel.
        let octant = |i: u32| -> usize {
            let q = local[i as usize];
            (0..3).map(|a| ((q[a] >= c[a]) as usize) << a).sum()
        };
        idx.sort_unstable_by_key(|&i| octant(i));
        let mut parts: Vec<(&mut [u32], [f64; 3], [f64; 3])> = Vec::new();
        let mut rest = idx;
        for o in 0..8 {
            let n = rest.iter().take_while(|&&i| octant(i) == o).count();
            let (part, tail) = rest.split_at_mut(n);
            rest = tail;
            if part.is_empty() {
                continue;
            }
            let (l, h): ([f64; 3], [f64; 3]) = (
                std::array::from_fn(|a| if o >> a & 1 == 1 { c[a] } else { lo[a] }),
                std::array::from_fn(|a| if o >> a & 1 == 1 { hi[a] } else { c[a] }),
            );
            parts.push((part, l, h));
        }
        parts.into_par_iter().for_each(|(part, l, h)| {
            self.occupancy_cell(field, local, part, l, h, depth + 1, answers)
        });
    }

    /// The distance tree, built on the first distance query: over the triangles with their slivers cut into
    /// pieces of at most a 128th of the mesh's extent (at most `distance_pieces`, which the budget counted):
    /// the slivers of one huge polygon's fan get tight boxes, where whole they overlap every query near the
    /// polygon (a prism of two 4,000-gons: every point tested thousands of slivers). The nearest piece names
    /// its triangle; the closest point and the distance are then the triangle's own.
    fn distance_tree(&self) -> &DistanceTree {
        self.distance.get_or_init(|| {
            let (lo, hi) = bounds(self.triangles.iter().flatten().copied());
            let extent = (0..3).map(|a| hi[a] - lo[a]).fold(0.0f64, f64::max);
            let pieces = distance_pieces(self.triangles.len());
            DistanceTree::new_split(&self.triangles, extent / 128.0, pieces)
        })
    }

    /// Distances signed by occupancy when `signed`, the nearest triangles searched on the CPU or (with
    /// `device`) on the device: what every distance call runs.
    fn distances_via(
        &self,
        points: &[[f64; 3]],
        signed: bool,
        device: Option<(&super::Gpu, bool)>,
    ) -> Result<(Distances, DeviceCheck)> {
        let inside = if signed {
            self.occupancy(points)?
        } else {
            Vec::new()
        };
        let (local, faces, check) = self.nearest(points, device)?;
        Ok((self.finish(&local, &faces, &inside, signed), check))
    }

    /// The nearest triangle of each point, searched once on the CPU or (with `device`) on the device,
    /// verified on the host when its flag says so ([`Self::distances_on`]): what [`Self::distance_rows`]
    /// makes unsigned and signed distances of without searching again.
    pub fn nearest_triangles(
        &self,
        points: &[[f64; 3]],
        device: Option<(&super::Gpu, bool)>,
    ) -> Result<Nearest> {
        let (local, faces, check) = self.nearest(points, device)?;
        Ok(Nearest {
            local,
            faces,
            check,
        })
    }

    /// The distance rows of `nearest`'s points: unsigned, or with `occupancy` (the points' own, from
    /// [`Self::occupancy`]) signed as [`Self::signed_distance`] signs; an error when `occupancy` does not
    /// have one entry per point.
    pub fn distance_rows(
        &self,
        nearest: &Nearest,
        occupancy: Option<&[bool]>,
    ) -> Result<Distances> {
        let inside = occupancy.unwrap_or(&[]);
        if occupancy.is_some() && inside.len() != nearest.faces.len() {
            return Err(Error::Invalid(format!(
                "{} occupancies for {} points",
                inside.len(),
                nearest.faces.len()
            )));
        }
        Ok(self.finish(&nearest.local, &nearest.faces, inside, occupancy.is_some()))
    }

    /// The points in the local frame and their nearest triangles (see [`Self::nearest_triangles`]); the
    /// points are checked first.
    #[allow(clippy::type_complexity)]
    fn nearest(
        &self,
        points: &[[f64; 3]],
        device: Option<(&super::Gpu, bool)>,
    ) -> Result<(Vec<[f64; 3]>, Vec<u32>, DeviceCheck)> {
        use crate::passes::closest_point::{nearest_slots_with, Search, INCOMPLETE};
        Self::check(points)?;
        let tree = self.distance_tree();
        let local: Vec<[f64; 3]> = points.iter().map(|&p| self.local(p)).collect();
        let device = device.filter(|(g, _)| g.context().info.features.shader_float64);
        let Some((gpu, verify)) = device.filter(|_| !points.is_empty()) else {
            let faces = tree
                .closest_all(&local, f64::INFINITY)
                .into_iter()
                .map(|c| c.expect("a prepared mesh has triangles").triangle)
                .collect();
            return Ok((local, faces, DeviceCheck::default()));
        };
        let pass = gpu.closest_point_pass()?;
        let layout = self.device_layout.get_or_init(|| tree.device_layout());
        let slots = nearest_slots_with(gpu.context(), &pass, layout, &local, Search::default())?;
        // (face, stopped short, checked, corrected)
        let rows: Vec<(u32, bool, bool, bool)> = local
            .par_iter()
            .zip(&slots)
            .map_init(Stack::default, |stack, (&q, &slot)| {
                let (found, done) = ((slot & !INCOMPLETE) as usize, slot & INCOMPLETE == 0);
                let device = tree.triangle_of(found);
                if let (Some(face), true, false) = (device, done, verify) {
                    return (face, false, false, false);
                }
                let mut hint = device.map(|_| found);
                let c = tree
                    .closest_within_from(q, f64::INFINITY, &mut hint, stack)
                    .expect("a prepared mesh has triangles");
                (c.triangle, !done, true, done && device != Some(c.triangle))
            })
            .collect();
        let count = |f: fn(&(u32, bool, bool, bool)) -> bool| rows.iter().filter(|r| f(r)).count();
        let check = DeviceCheck {
            incomplete: count(|r| r.1),
            checked: count(|r| r.2),
            corrected: count(|r| r.3),
        };
        let faces = rows.into_iter().map(|r| r.0).collect();
        Ok((local, faces, check))
    }

    /// The rows of `local`'s points from their nearest triangles `faces`: the triangle's own closest point
    /// and distance, signed by `inside` when `signed` (a point on the surface keeps 0).
    fn finish(
        &self,
        local: &[[f64; 3]],
        faces: &[u32],
        inside: &[bool],
        signed: bool,
    ) -> Distances {
        let rows: Vec<(f32, [f64; 3], u32, [f64; 3])> = faces
            .par_iter()
            .enumerate()
            .map(|(i, &face)| {
                let (point, barycentric, distance2) =
                    closest_point(local[i], &self.triangles[face as usize]);
                let mut d = distance2.sqrt() as f32;
                if signed && d > 0.0 && inside[i] == (self.opts.sdf_sign == SdfSign::InsideNegative)
                {
                    d = -d;
                }
                let world = std::array::from_fn(|a| point[a] + self.shift[a]);
                (d, world, face, barycentric)
            })
            .collect();
        let mut out = Distances::default();
        for (d, p, f, b) in rows {
            out.distance.push(d);
            out.closest.push(p);
            out.face.push(f);
            out.barycentric.push(b);
        }
        out
    }

    /// The distances ([`Self::unsigned_distance`], or with `signed` [`Self::signed_distance`]) with the
    /// nearest pieces searched on `gpu`'s device (`passes::closest_point`, in f64, the CPU's search
    /// operation for operation with its quotients rounded as the CPU's: the same pieces). A search the
    /// device stopped short is finished on the host from its best piece. With `verify`, every answer is
    /// checked on the host: the device's piece starts the CPU's own search as its hint
    /// ([`DistanceTree::closest_within_from`]), which returns the CPU's answer whatever the device
    /// computed, and [`DeviceCheck::corrected`] counts the points where they differed. Without
    /// `shaderFloat64` the CPU searches alone.
    pub fn distances_on(
        &self,
        gpu: &super::Gpu,
        points: &[[f64; 3]],
        signed: bool,
        verify: bool,
    ) -> Result<(Distances, DeviceCheck)> {
        self.distances_via(points, signed, Some((gpu, verify)))
    }

    /// [`Self::unsigned_distance`] with the nearest triangles searched on `gpu`'s device: the same rows
    /// ([`Self::distances_on`] without the host's check).
    pub fn unsigned_distance_on(
        &self,
        gpu: &super::Gpu,
        points: &[[f64; 3]],
    ) -> Result<(Distances, DeviceCheck)> {
        self.distances_on(gpu, points, false, false)
    }

    /// [`Self::signed_distance`] with the nearest triangles searched on `gpu`'s device (the sign is the
    /// CPU's exact occupancy): the same rows ([`Self::distances_on`] without the host's check).
    pub fn signed_distance_on(
        &self,
        gpu: &super::Gpu,
        points: &[[f64; 3]],
    ) -> Result<(Distances, DeviceCheck)> {
        self.distances_on(gpu, points, true, false)
    }

    /// Distances to the surface, with the nearest triangles.
    pub fn unsigned_distance(&self, points: &[[f64; 3]]) -> Result<Distances> {
        self.distances_via(points, false, None).map(|d| d.0)
    }

    /// Distances signed by the exact winding number (see the module docs).
    pub fn signed_distance(&self, points: &[[f64; 3]]) -> Result<Distances> {
        self.distances_via(points, true, None).map(|d| d.0)
    }

    /// The options it was prepared with.
    pub fn options(&self) -> &QueryOptions {
        &self.opts
    }
}

/// Pieces the distance tree of `n` triangles may hold: an eighth more than the triangles, and at least
/// 2^18 (room for the slivers of a few huge polygons on a small mesh).
fn distance_pieces(n: usize) -> usize {
    (n + n / 8).max(1 << 18)
}

/// Bytes one piece of the distance tree takes at most (corners, plane, sphere, index, its share of nodes).
const DISTANCE_PIECE_BYTES: u64 = 160;

/// The box of `points` (min, max corners).
fn bounds(points: impl IntoIterator<Item = [f64; 3]>) -> ([f64; 3], [f64; 3]) {
    points.into_iter().fold(
        ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
        |(lo, hi), p| {
            (
                std::array::from_fn(|a| lo[a].min(p[a])),
                std::array::from_fn(|a| hi[a].max(p[a])),
            )
        },
    )
}

/// The longest side of the box of the triangles' vertices (1 for a degenerate box).
fn extent(tri: &TriMesh) -> f64 {
    let (lo, hi) = bounds(
        tri.triangles
            .iter()
            .flatten()
            .map(|&v| tri.positions[v as usize].map(f64::from)),
    );
    let e = (0..3).map(|a| hi[a] - lo[a]).fold(0.0f64, f64::max);
    if e > 0.0 {
        e
    } else {
        1.0
    }
}

/// Exact winding numbers of `mesh` at `points` (see [`MeshQuery`] to reuse the preparation).
pub fn winding_numbers(mesh: &Mesh, points: &[[f64; 3]]) -> Result<Vec<f64>> {
    MeshQuery::new(mesh, &QueryOptions::default())?.winding_numbers(points)
}

/// Occupancy (|w| ≥ ½) of `mesh` at `points`.
pub fn occupancy(mesh: &Mesh, points: &[[f64; 3]]) -> Result<Vec<bool>> {
    MeshQuery::new(mesh, &QueryOptions::default())?.occupancy(points)
}

/// Distances from `points` to `mesh`, with the nearest triangles.
pub fn unsigned_distance(mesh: &Mesh, points: &[[f64; 3]]) -> Result<Distances> {
    MeshQuery::distances_only(mesh, &QueryOptions::default())?.unsigned_distance(points)
}

/// Distances from `points` to `mesh`, negative inside (the exact winding number's |w| ≥ ½).
pub fn signed_distance(mesh: &Mesh, points: &[[f64; 3]]) -> Result<Distances> {
    MeshQuery::new(mesh, &QueryOptions::default())?.signed_distance(points)
}

/// One sampler of a dataset recipe (`--sample uniform:N,near:σ:N,surface:N`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SampleSpec {
    /// N points uniform in the mesh's box padded by `pad` of its size on each side.
    Uniform(usize),
    /// N area-weighted surface points moved by normal offsets of standard deviation σ (mesh units) per axis.
    Near { sigma: f64, n: usize },
    /// N area-weighted surface points with their triangles' normals (not queried: they lie on the surface).
    Surface(usize),
}

impl SampleSpec {
    /// Parses `uniform:N,near:SIGMA:N,surface:N` (any order, any repeats).
    pub fn parse_list(text: &str) -> Result<Vec<SampleSpec>> {
        let bad = |part: &str, why: &str| {
            Error::Invalid(format!(
                "--sample {part}: {why} (expected uniform:N, near:SIGMA:N or surface:N)"
            ))
        };
        let count = |part: &str, n: &str| -> Result<usize> {
            n.parse::<usize>()
                .ok()
                .filter(|&n| n > 0 && n <= MAX_SAMPLES)
                .ok_or_else(|| bad(part, &format!("a count from 1 to {MAX_SAMPLES}")))
        };
        text.split(',')
            .map(|part| {
                let f: Vec<&str> = part.trim().split(':').collect();
                match f.as_slice() {
                    ["uniform", n] => Ok(SampleSpec::Uniform(count(part, n)?)),
                    ["surface", n] => Ok(SampleSpec::Surface(count(part, n)?)),
                    ["near", s, n] => {
                        let sigma = s
                            .parse::<f64>()
                            .ok()
                            .filter(|x| x.is_finite() && *x > 0.0)
                            .ok_or_else(|| bad(part, "σ must be a positive number"))?;
                        Ok(SampleSpec::Near {
                            sigma,
                            n: count(part, n)?,
                        })
                    }
                    _ => Err(bad(part, "unknown sampler")),
                }
            })
            .collect()
    }
}

/// Most points one sampler may ask for (a billion: 24 GB of f64 points).
pub const MAX_SAMPLES: usize = 1_000_000_000;

/// Sampled points (world coordinates).
#[derive(Clone, Debug, Default)]
pub struct Samples {
    /// The uniform and near-surface points, sampler by sampler in the order given: what gets queried.
    pub points: Vec<[f64; 3]>,
    /// The surface samplers' points and their normals.
    pub surface_points: Vec<[f64; 3]>,
    pub surface_normals: Vec<[f64; 3]>,
}

impl MeshQuery {
    /// Draws `specs` with `seed` (sampler k uses the stream `seed` + k, so adding a sampler does not move
    /// the others' points); uniform boxes are padded by `pad` × the box's size on each side.
    pub fn sample(&self, specs: &[SampleSpec], pad: f64, seed: u64) -> Result<Samples> {
        use crate::geom::random::SplitMix64;
        use crate::mesh::sample;
        if !(pad.is_finite() && pad >= 0.0) {
            return Err(Error::Invalid(format!("--pad must be ≥ 0, not {pad}")));
        }
        let total: usize = specs
            .iter()
            .map(|s| match *s {
                SampleSpec::Uniform(n) | SampleSpec::Surface(n) | SampleSpec::Near { n, .. } => n,
            })
            .sum();
        if total as u64 * 48 > self.opts.budget {
            return Err(Error::Budget {
                what: format!("{total} sample points"),
                detail: format!("the query budget of {} MiB", self.opts.budget >> 20),
            });
        }
        let table = sample::area_table(&self.triangles);
        let (lo, hi) = bounds(self.triangles.iter().flatten().copied());
        let world = |p: [f64; 3]| -> [f64; 3] { std::array::from_fn(|a| p[a] + self.shift[a]) };
        let mut out = Samples::default();
        for (k, spec) in specs.iter().enumerate() {
            let mut rng = SplitMix64(seed.wrapping_add(k as u64));
            match *spec {
                SampleSpec::Uniform(n) => {
                    let (l, h): ([f64; 3], [f64; 3]) = (
                        std::array::from_fn(|a| lo[a] - pad * (hi[a] - lo[a])),
                        std::array::from_fn(|a| hi[a] + pad * (hi[a] - lo[a])),
                    );
                    out.points
                        .extend(sample::uniform(l, h, n, &mut rng).into_iter().map(world));
                }
                SampleSpec::Near { sigma, n } => out.points.extend(
                    sample::near(&self.triangles, &table, sigma, n, &mut rng)
                        .into_iter()
                        .map(world),
                ),
                SampleSpec::Surface(n) => {
                    let (p, nrm) = sample::surface(&self.triangles, &table, n, &mut rng);
                    out.surface_points.extend(p.into_iter().map(world));
                    out.surface_normals.extend(nrm);
                }
            }
        }
        Ok(out)
    }
}

/// What a [`QueryJob`] computes at its points (the `--what` names).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QueryWhat {
    /// `winding`: float64.
    Winding,
    /// `occupancy`: bool (packed bits with [`QueryJob::compact`]).
    Occupancy,
    /// `sdf`: float32, signed as [`QueryOptions::sdf_sign`].
    Sdf,
    /// `udf`: float32.
    Udf,
}

impl QueryWhat {
    /// The array's name in the `.npz`, and the `--what` word.
    pub fn name(self) -> &'static str {
        match self {
            QueryWhat::Winding => "winding",
            QueryWhat::Occupancy => "occupancy",
            QueryWhat::Sdf => "sdf",
            QueryWhat::Udf => "udf",
        }
    }

    /// Parses `--what` words (`winding`, `occupancy`, `sdf`, `udf`; any order, no repeats needed).
    pub fn parse_list<S: AsRef<str>>(words: &[S]) -> Result<Vec<QueryWhat>> {
        words
            .iter()
            .map(|w| match w.as_ref().trim() {
                "winding" => Ok(QueryWhat::Winding),
                "occupancy" => Ok(QueryWhat::Occupancy),
                "sdf" => Ok(QueryWhat::Sdf),
                "udf" => Ok(QueryWhat::Udf),
                other => Err(Error::Invalid(format!(
                    "--what {other}: expected winding, occupancy, sdf or udf"
                ))),
            })
            .collect()
    }
}

/// Where a [`QueryJob`]'s points come from.
#[derive(Clone, Debug)]
pub enum QueryPoints {
    /// The same points for every model (world coordinates).
    Given(std::sync::Arc<Vec<[f64; 3]>>),
    /// Drawn from each model ([`MeshQuery::sample`]).
    Sample {
        specs: Vec<SampleSpec>,
        pad: f64,
        seed: u64,
    },
}

impl QueryPoints {
    /// What is computed when nothing is asked: occupancy at drawn points (the dataset recipes' label), the
    /// winding number and occupancy at given ones.
    pub fn default_what(&self) -> Vec<QueryWhat> {
        match self {
            QueryPoints::Sample { .. } => vec![QueryWhat::Occupancy],
            QueryPoints::Given(_) => vec![QueryWhat::Winding, QueryWhat::Occupancy],
        }
    }
}

/// One model's query, as `gregvox query` and `gregvox batch --query` run it: prepare the mesh, take or draw
/// the points, compute what is asked, and return the arrays of the `.npz` in their order (`surface_points`
/// and `surface_normals` when a surface sampler is asked, `points` when the points were drawn, then each
/// name asked, then `face`, `closest` and `barycentric` with [`QueryJob::closest`]).
#[derive(Clone, Debug)]
pub struct QueryJob {
    pub what: Vec<QueryWhat>,
    pub points: QueryPoints,
    /// The Occupancy Networks layout: occupancy as packed bits (uint8) and drawn points as float16.
    pub compact: bool,
    /// Also the nearest triangle, closest point and barycentric coordinates (needs sdf or udf).
    pub closest: bool,
    pub opts: QueryOptions,
}

/// What [`QueryJob::run`] made.
pub struct QueryOutput {
    /// The `.npz` arrays, in order.
    pub arrays: Vec<(&'static str, crate::npy::Array)>,
    /// Points queried.
    pub points: usize,
    /// Points found inside, when occupancy was asked.
    pub inside: Option<u64>,
    /// Seconds preparing the mesh (trees and indices).
    pub prepare_seconds: f64,
    /// The seed the points were drawn with (`None` for given points).
    pub seed: Option<u64>,
    /// With a device: what the host did after its distance search (one search for sdf and udf alike);
    /// `None` when no distance was searched on a device.
    pub device_check: Option<DeviceCheck>,
}

/// A 64-bit FNV-1a hash (the per-model seed of [`QueryJob::for_model`]).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

impl QueryJob {
    /// Checks the job before any model is read: something to compute, `closest` with a distance.
    pub fn check(&self) -> Result<()> {
        if self.what.is_empty() {
            return Err(Error::Invalid("--what: nothing to compute".into()));
        }
        if self.closest
            && !self
                .what
                .iter()
                .any(|w| matches!(w, QueryWhat::Sdf | QueryWhat::Udf))
        {
            return Err(Error::Invalid(
                "--closest needs sdf or udf in --what".into(),
            ));
        }
        if let QueryPoints::Sample { pad, .. } = self.points {
            if !(pad.is_finite() && pad >= 0.0) {
                return Err(Error::Invalid(format!("--pad must be ≥ 0, not {pad}")));
            }
        }
        Ok(())
    }

    /// The job for the model at `relative` (its path below the batch's input folder): drawn points take the
    /// seed `seed ⊕ FNV-1a(relative path)`, so models get independent samples, and a model gets the same
    /// ones however the list is sharded or resumed. Given points are kept.
    pub fn for_model(&self, relative: &std::path::Path) -> QueryJob {
        let mut job = self.clone();
        if let QueryPoints::Sample { seed, .. } = &mut job.points {
            *seed ^= fnv1a(relative.to_string_lossy().as_bytes());
        }
        job
    }

    /// The seed the points are drawn with (`None` for given points).
    pub fn seed(&self) -> Option<u64> {
        match self.points {
            QueryPoints::Sample { seed, .. } => Some(seed),
            QueryPoints::Given(_) => None,
        }
    }

    /// Runs the job on `mesh`. `deadline` is checked after the preparation and between the queries.
    pub fn run(&self, mesh: &Mesh, deadline: &Option<super::Deadline>) -> Result<QueryOutput> {
        self.run_on(mesh, deadline, None, false)
    }

    /// [`QueryJob::run`] with the distances' nearest triangles searched on `gpu`'s device (the same arrays;
    /// with `verify` every answer checked on the host: [`MeshQuery::distances_on`]).
    pub fn run_on(
        &self,
        mesh: &Mesh,
        deadline: &Option<super::Deadline>,
        gpu: Option<&super::Gpu>,
        verify: bool,
    ) -> Result<QueryOutput> {
        use crate::engine::voxelize::checkpoint;
        use crate::npy::Array;
        self.check()?;
        let want = |w: QueryWhat| self.what.contains(&w);
        let f32_rows =
            |v: &[[f64; 3]]| -> Vec<[f32; 3]> { v.iter().map(|p| p.map(|x| x as f32)).collect() };
        let start = std::time::Instant::now();
        // Unsigned distances alone need no winding number: no weld, caps or crossing index.
        let q = if self.what.iter().all(|&w| w == QueryWhat::Udf) {
            MeshQuery::distances_only(mesh, &self.opts)?
        } else {
            MeshQuery::new(mesh, &self.opts)?
        };
        let prepare_seconds = start.elapsed().as_secs_f64();
        checkpoint(deadline, "after preparing the mesh")?;
        let mut arrays: Vec<(&'static str, Array)> = Vec::new();
        let drawn;
        let points: &[[f64; 3]] = match &self.points {
            QueryPoints::Given(p) => p,
            QueryPoints::Sample { specs, pad, seed } => {
                let s = q.sample(specs, *pad, *seed)?;
                if !s.surface_points.is_empty() {
                    arrays.push((
                        "surface_points",
                        Array::points_f32(&f32_rows(&s.surface_points)),
                    ));
                    arrays.push((
                        "surface_normals",
                        Array::points_f32(&f32_rows(&s.surface_normals)),
                    ));
                }
                let p32 = f32_rows(&s.points);
                let written = if self.compact {
                    Array::points_f16(&p32)
                } else {
                    Array::points_f32(&p32)
                };
                // The points as written are the points queried (f32 or f16 rounding included), so the
                // answers describe the file's points exactly.
                drawn = if self.compact {
                    written
                        .data
                        .chunks(6)
                        .map(|c| {
                            std::array::from_fn(|k| {
                                half::f16::from_le_bytes([c[2 * k], c[2 * k + 1]]).to_f64()
                            })
                        })
                        .collect()
                } else {
                    p32.iter().map(|p| p.map(f64::from)).collect::<Vec<_>>()
                };
                arrays.push(("points", written));
                checkpoint(deadline, "after drawing the points")?;
                &drawn
            }
        };
        let mut inside = None;
        // Occupancy once, for its array and for the sdf's sign.
        let mut occupancy: Option<Vec<bool>> = None;
        if want(QueryWhat::Winding) || want(QueryWhat::Occupancy) {
            let (w, occ) = if want(QueryWhat::Winding) {
                q.winding_and_occupancy(points)?
            } else {
                (Vec::new(), q.occupancy(points)?)
            };
            if want(QueryWhat::Winding) {
                arrays.push(("winding", Array::f64s(&w)));
            }
            if want(QueryWhat::Occupancy) {
                inside = Some(occ.iter().filter(|&&o| o).count() as u64);
                arrays.push((
                    "occupancy",
                    if self.compact {
                        Array::packed_bits(&occ)
                    } else {
                        Array::bools(&occ)
                    },
                ));
            }
            occupancy = Some(occ);
            checkpoint(deadline, "after the winding numbers")?;
        }
        let mut closest: Option<Distances> = None;
        let mut device_check: Option<DeviceCheck> = None;
        if want(QueryWhat::Sdf) || want(QueryWhat::Udf) {
            if want(QueryWhat::Sdf) && occupancy.is_none() {
                occupancy = Some(q.occupancy(points)?);
            }
            // The nearest triangles once, for sdf and udf alike.
            let nearest = q.nearest_triangles(points, gpu.map(|g| (g, verify)))?;
            if gpu.is_some() {
                device_check = Some(nearest.check);
            }
            for (what, signed) in [(QueryWhat::Sdf, true), (QueryWhat::Udf, false)] {
                if want(what) {
                    let d = q.distance_rows(&nearest, occupancy.as_deref().filter(|_| signed))?;
                    arrays.push((what.name(), Array::f32s(&d.distance)));
                    closest.get_or_insert(d);
                }
            }
            checkpoint(deadline, "after the distances")?;
        }
        if self.closest {
            if let Some(d) = closest {
                arrays.push(("face", Array::u32s(&d.face)));
                arrays.push(("closest", Array::points_f32(&f32_rows(&d.closest))));
                arrays.push(("barycentric", Array::points_f32(&f32_rows(&d.barycentric))));
            }
        }
        Ok(QueryOutput {
            arrays,
            points: points.len(),
            inside,
            prepare_seconds,
            seed: self.seed(),
            device_check,
        })
    }
}
